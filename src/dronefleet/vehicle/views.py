"""The seed's UAVObject views of flight-controller state (``objrequest``, seed 4.1.2.1).

Every backend answers ``objrequest FlightBatteryState`` and friends with the same fields, whatever
protocol it speaks, and the UAVTalk simulator serves the same values over real bytes.
"""

from __future__ import annotations

from typing import Any

from dronefleet.vehicle.base import BatteryState


def flight_battery_state(bat: BatteryState) -> dict[str, Any]:
    """FlightBatteryState: volts, amps, mAh, and the flight time left at the present draw (s)."""
    left_mah = bat.capacity_mah * bat.remaining_pct / 100.0
    return {
        "Voltage": bat.voltage_v,
        "Current": bat.current_a,
        "ConsumedEnergy": bat.consumed_mah,
        "Capacity": bat.capacity_mah,
        "RemainingPct": bat.remaining_pct,
        "NbCells": bat.cell_count,
        "EstimatedFlightTime": left_mah * 3.6 / bat.current_a if bat.current_a > 0 else 0.0,
    }
