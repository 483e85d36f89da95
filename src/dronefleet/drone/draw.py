"""The current a vehicle draws in the air, measured for the planner's battery estimates (issue 17).

The planner's default model is the dissertation's quad (18 A hovering); ArduPilot's Copter SITL
draws about 28 A. A drone therefore tells the ground what it was measured to draw: the charge the
autopilot reports used (BATTERY_STATUS ``current_consumed``) while airborne, over the time
airborne, summed over every flight since the drone started — a mean, so hover, climbs and
cruise weigh as they were flown. When the autopilot reports no used charge, a running mean of
the instantaneous current stands in.
"""

from __future__ import annotations

#: Airborne seconds before the charge-based mean is trusted.
MIN_AIRBORNE_S = 10.0


class FlightDraw:
    def __init__(self) -> None:
        self.charge_mah = 0.0
        self.airborne_s = 0.0
        self._last: tuple[float, float] | None = None  # (vehicle time, consumed mAh) in the air
        self._running_a: float | None = None

    def sample(
        self, now_s: float, consumed_mah: float | None, current_a: float | None, in_air: bool
    ) -> None:
        if not in_air:
            self._last = None
            return
        if current_a is not None and current_a > 0:
            mean = self._running_a
            self._running_a = current_a if mean is None else mean + 0.2 * (current_a - mean)
        if consumed_mah is None or consumed_mah <= 0:
            return
        if self._last is not None:
            then, before = self._last
            if now_s > then and consumed_mah >= before:
                self.airborne_s += now_s - then
                self.charge_mah += consumed_mah - before
        self._last = (now_s, consumed_mah)

    @property
    def mean_a(self) -> float | None:
        """Amperes drawn in the air on average, or None before anything was measured."""
        if self.airborne_s >= MIN_AIRBORNE_S and self.charge_mah > 0:
            return self.charge_mah * 3.6 / self.airborne_s  # mAh/s → A
        return self._running_a
