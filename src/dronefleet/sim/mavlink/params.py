"""The simulated autopilot's parameters: ArduPilot Copter 4.5's (:mod:`.param_table`), so ground
stations find the names they read, and a few of which change how the sim flies.

Values are floats as on the wire (PARAM_VALUE carries float32); names and units are ArduPilot's
(WPNAV_* in cm and cm/s, RTL_ALT in cm, BATT_CAPACITY in mAh).
"""

from __future__ import annotations

from collections.abc import Callable

from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.sim.mavlink.param_table import DEFAULTS, SIM_CONFIG

_REAL32 = mav.MAV_PARAM_TYPE_REAL32


class ParamTable:
    """Ordered parameters with change hooks."""

    def __init__(self, overrides: dict[str, float] | None = None) -> None:
        self._values = {name: [value, kind] for name, (value, kind) in DEFAULTS.items()}
        self._hooks: list[Callable[[str, float], None]] = []
        for name, value in {**SIM_CONFIG, **(overrides or {})}.items():
            self._values.setdefault(name, [value, _REAL32])[0] = value
        self._names = list(self._values)
        self._index = {name: i for i, name in enumerate(self._names)}

    def on_change(self, hook: Callable[[str, float], None]) -> None:
        self._hooks.append(hook)

    def names(self) -> list[str]:
        return list(self._names)

    def __len__(self) -> int:
        return len(self._names)

    def __contains__(self, name: object) -> bool:
        return name in self._index

    def get(self, name: str) -> float:
        return float(self._values[name][0])

    def kind(self, name: str) -> int:
        return int(self._values[name][1])

    def index(self, name: str) -> int:
        return self._index[name]

    def set(self, name: str, value: float) -> bool:
        """Set a known parameter (unknown names are refused, as the autopilot does)."""
        entry = self._values.get(name)
        if entry is None:
            return False
        entry[0] = float(value) if entry[1] == _REAL32 else round(value)
        for hook in self._hooks:
            hook(name, float(entry[0]))
        return True

    def message(self, name: str) -> mav.MAVLink_param_value_message:
        value, kind = self._values[name]
        return mav.MAVLink_param_value_message(
            name.encode(), float(value), kind, len(self._names), self._index[name]
        )

    def message_at(self, index: int) -> mav.MAVLink_param_value_message | None:
        names = self._names
        return self.message(names[index]) if 0 <= index < len(names) else None
