"""The simulated autopilot's parameters: enough of ArduPilot Copter's for ground stations to
connect (they download the whole list first) and for the few that change how the sim flies.

Values are floats as on the wire (PARAM_VALUE carries float32); names and units are ArduPilot's
(WPNAV_* in cm and cm/s, RTL_ALT in cm, BATT_CAPACITY in mAh).
"""

from __future__ import annotations

from collections.abc import Callable

from dronefleet.protocols.mavlink.codec import dialect as mav

_INT32 = mav.MAV_PARAM_TYPE_INT32
_REAL32 = mav.MAV_PARAM_TYPE_REAL32

DEFAULTS: dict[str, tuple[float, int]] = {
    "SYSID_THISMAV": (1, _INT32),
    "SYSID_MYGCS": (255, _INT32),
    "FRAME_CLASS": (1, _INT32),  # quad
    "FRAME_TYPE": (1, _INT32),  # X
    "ARMING_CHECK": (1, _INT32),
    "WPNAV_SPEED": (1000, _REAL32),
    "WPNAV_SPEED_UP": (200, _REAL32),
    "WPNAV_SPEED_DN": (150, _REAL32),
    "WPNAV_ACCEL": (250, _REAL32),
    "WPNAV_RADIUS": (200, _REAL32),
    "RTL_ALT": (1500, _INT32),
    "LAND_SPEED": (50, _INT32),  # cm/s below LAND_ALT_LOW
    "LAND_ALT_LOW": (1000, _INT32),  # cm: above it a landing descends at WPNAV_SPEED_DN
    "DISARM_DELAY": (10, _INT32),  # s on the ground, armed and idle, before an auto-disarm
    "BATT_MONITOR": (4, _INT32),
    "BATT_CAPACITY": (5500, _INT32),
    "BATT_LOW_MAH": (275, _INT32),
    "FS_BATT_ENABLE": (1, _INT32),  # land
    "FS_GCS_ENABLE": (0, _INT32),  # keep flying a mission when the ground goes quiet
    # Geofence (AC_Fence; Copter's defaults): off until enabled; max altitude, circle, polygon.
    "FENCE_ENABLE": (0, _INT32),
    "FENCE_TYPE": (7, _INT32),
    "FENCE_ACTION": (1, _INT32),  # RTL, else land
    "FENCE_ALT_MAX": (100, _REAL32),  # m
    "FENCE_RADIUS": (300, _REAL32),  # m
    "FENCE_MARGIN": (2, _REAL32),  # m
    "SR0_POSITION": (5, _INT32),
    "SR0_EXTRA1": (5, _INT32),
}


class ParamTable:
    """Ordered parameters with change hooks."""

    def __init__(self, overrides: dict[str, float] | None = None) -> None:
        self._values = {name: [value, kind] for name, (value, kind) in DEFAULTS.items()}
        self._hooks: list[Callable[[str, float], None]] = []
        for name, value in (overrides or {}).items():
            self._values.setdefault(name, [value, _REAL32])[0] = value

    def on_change(self, hook: Callable[[str, float], None]) -> None:
        self._hooks.append(hook)

    def names(self) -> list[str]:
        return list(self._values)

    def get(self, name: str) -> float:
        return float(self._values[name][0])

    def index(self, name: str) -> int:
        return self.names().index(name)

    def set(self, name: str, value: float) -> bool:
        """Set a known parameter (unknown names are refused, as the autopilot does)."""
        entry = self._values.get(name)
        if entry is None:
            return False
        entry[0] = round(value) if entry[1] == _INT32 else float(value)
        for hook in self._hooks:
            hook(name, float(entry[0]))
        return True

    def message(self, name: str) -> mav.MAVLink_param_value_message:
        value, kind = self._values[name]
        return mav.MAVLink_param_value_message(
            name.encode(), float(value), kind, len(self._values), self.index(name)
        )

    def message_at(self, index: int) -> mav.MAVLink_param_value_message | None:
        names = self.names()
        return self.message(names[index]) if 0 <= index < len(names) else None
