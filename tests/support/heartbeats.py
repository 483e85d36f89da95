"""A drone's heartbeat as it goes on the wire, for tests that hand one in or forge one."""

from __future__ import annotations

import orjson


def heartbeat(drone_id: str, vehicle_time_s: float) -> bytes:
    """A disarmed drone's heartbeat (JSON): at 40.63, -8.659, 10 m; battery 90 %, 16 V."""
    return orjson.dumps({
        "drone_id": drone_id, "vehicle_time_s": vehicle_time_s,
        "position": {"lat": 40.63, "lon": -8.659, "alt_m": 10.0},
        "battery": {"remaining_pct": 90.0, "voltage_v": 16.0}, "state": "disarmed",
        "mode": "GUIDED",
    })  # fmt: skip
