"""The flight battery: a 4S 5500 mAh LiPo as on the seed's drones (section 4.1.1).

Current depends on what the frame does (idle on the ground, hovering, fast forward flight,
climbing); voltage follows a per-cell open-circuit curve of the state of charge and sags with
current through the pack's internal resistance. Remaining charge drives the battery failsafe in
:class:`~dronefleet.sim.vehicle.SimVehicle`.
"""

from __future__ import annotations

import bisect

from dronefleet.vehicle.base import BatteryState

#: Open-circuit voltage of one LiPo cell against state of charge (0..1): 4.2 V full, 3.3 V empty.
_OCV_SOC = (0.0, 0.05, 0.10, 0.20, 0.40, 0.60, 0.80, 0.90, 1.0)
_OCV_V = (3.30, 3.50, 3.62, 3.70, 3.77, 3.85, 3.98, 4.07, 4.20)

#: Extra current at full airspeed, as a fraction of hover current (parasitic drag, tilt).
_FORWARD_FACTOR = 0.5
#: Extra current per m/s of climb, as a fraction of hover current; descending saves a little.
_CLIMB_FACTOR_PER_MPS = 0.1
_DESCENT_FACTOR_PER_MPS = 0.05


def cell_ocv_v(soc: float) -> float:
    """Open-circuit voltage of one cell at state of charge ``soc`` (0..1)."""
    soc = min(1.0, max(0.0, soc))
    i = bisect.bisect_right(_OCV_SOC, soc)
    if i >= len(_OCV_SOC):
        return _OCV_V[-1]
    s0, s1 = _OCV_SOC[i - 1], _OCV_SOC[i]
    v0, v1 = _OCV_V[i - 1], _OCV_V[i]
    return v0 + (v1 - v0) * (soc - s0) / (s1 - s0)


class Battery:
    """Charge bookkeeping and a current model for one pack."""

    def __init__(
        self,
        capacity_mah: float = 5500.0,
        cell_count: int = 4,
        initial_charge_pct: float = 100.0,
        hover_current_a: float = 18.0,
        idle_current_a: float = 0.5,
        armed_idle_current_a: float = 3.0,
        cell_resistance_ohm: float = 0.006,
    ) -> None:
        if capacity_mah <= 0 or cell_count <= 0:
            raise ValueError("battery capacity and cell count must be positive")
        if not 0.0 <= initial_charge_pct <= 100.0:
            raise ValueError(f"initial charge must be 0..100 %, got {initial_charge_pct}")
        self.capacity_mah = float(capacity_mah)
        self.cell_count = int(cell_count)
        self.initial_charge_pct = float(initial_charge_pct)
        self.hover_current_a = hover_current_a
        self.idle_current_a = idle_current_a
        self.armed_idle_current_a = armed_idle_current_a
        self.cell_resistance_ohm = cell_resistance_ohm
        self.consumed_mah = 0.0
        self.current_a = idle_current_a

    # -- model --------------------------------------------------------------------------------
    def flight_current_a(
        self, airspeed_mps: float, climb_mps: float, max_speed_mps: float
    ) -> float:
        """Current drawn in the air: hover, plus forward flight, plus climb (``climb_mps`` > 0
        up)."""
        ratio = airspeed_mps / max_speed_mps
        factor = 1.0 + _FORWARD_FACTOR * ratio * ratio
        if climb_mps > 0:
            factor += _CLIMB_FACTOR_PER_MPS * climb_mps
        else:
            factor += _DESCENT_FACTOR_PER_MPS * climb_mps
        return self.hover_current_a * factor

    def draw(self, current_a: float, dt_s: float) -> None:
        self.current_a = current_a
        self.consumed_mah += current_a * dt_s / 3.6  # A·s -> mAh

    def swap(self) -> None:
        """A fresh, full pack of the same kind in place of this one (a battery swap)."""
        self.initial_charge_pct = 100.0
        self.consumed_mah = 0.0

    # -- readings -----------------------------------------------------------------------------
    @property
    def remaining_pct(self) -> float:
        return max(0.0, self.initial_charge_pct - 100.0 * self.consumed_mah / self.capacity_mah)

    @property
    def voltage_v(self) -> float:
        cell = cell_ocv_v(self.remaining_pct / 100.0) - self.current_a * self.cell_resistance_ohm
        return self.cell_count * max(0.0, cell)

    def state(self) -> BatteryState:
        return BatteryState(
            remaining_pct=self.remaining_pct,
            voltage_v=self.voltage_v,
            current_a=self.current_a,
            consumed_mah=self.consumed_mah,
            capacity_mah=self.capacity_mah,
            cell_count=self.cell_count,
        )
