"""How the simulated Copter comes down and disarms, as ArduPilot Copter 4.5 does (issue 10, item 5).

- A landing descends at LAND_SPEED_HIGH (or WPNAV_SPEED_DN when that is 0), slowing down to reach
  LAND_SPEED by LAND_ALT_LOW, then at LAND_SPEED (ArduCopter ``Mode::land_run_vertical_control``
  and ``get_land_descent_speed``): from 10 m, ~20 s; from 30 m, ~34 s.
- Once down, the land detector needs a second on the ground (LAND_DETECTOR_TRIGGER_SEC) before
  it says landed, and a landing (LAND, RTL, a mission's LAND) then disarms (``ModeLand::run``:
  "disarm when the landing detector says we've landed"); it is not DISARM_DELAY that ends it.
- Armed, on the ground and idle otherwise (armed and never took off, or a GUIDED target that
  left it on the ground), it disarms after DISARM_DELAY seconds (``Copter::auto_disarm_check``).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

from dronefleet.protocols.mavlink.codec import dialect as mav

if TYPE_CHECKING:
    from dronefleet.sim.mavlink.copter import SimCopter

#: Seconds on the ground before ArduPilot's land detector says landed.
LAND_DETECTOR_S = 1.0


class Landing:
    """Descent speeds and the disarms after landing, for one :class:`SimCopter`."""

    def __init__(self, copter: SimCopter) -> None:
        self.copter = copter
        copter.vehicle.disarm_on_touchdown = False  # the land detector decides, below
        self._landing = False  # a landing is under way (or just ended on the ground)
        self._down_since_s: float | None = None
        self._idle_since_s: float | None = None

    def update(self) -> None:
        self._descent_speed()
        self._landed_disarm()
        self._auto_disarm()

    def _descent_speed(self) -> None:
        v, p = self.copter.vehicle, self.copter.params
        fast = p.get("WPNAV_SPEED_DN") / 100.0
        high = p.get("LAND_SPEED_HIGH") / 100.0
        slow = p.get("LAND_SPEED") / 100.0
        if v.landing:
            above_low_m = v.relative_alt_m - p.get("LAND_ALT_LOW") / 100.0
            descent = high if high > 0 else fast
            if slow > 0:  # slowing down to LAND_SPEED by LAND_ALT_LOW (ArduPilot's sqrt_controller)
                braking = math.sqrt(2 * v.limits.accel_z_mps2 * max(above_low_m, 0.0))
                descent = max(min(descent, slow + braking), slow)
        else:
            descent = fast
        if descent > 0 and v.limits.max_descent_mps != descent:
            v.limits = replace(v.limits, max_descent_mps=descent)

    def _landed_disarm(self) -> None:
        v = self.copter.vehicle
        if v.landing:
            self._landing, self._down_since_s = True, None
            return
        if not v.armed or v.in_air:  # disarmed (forced), or flying again before it settled
            self._landing = False
        if not self._landing:
            self._down_since_s = None
            return
        if self._down_since_s is None:
            self._down_since_s = v.time_s
        elif v.time_s - self._down_since_s >= LAND_DETECTOR_S - 1e-9:
            self._landing, self._down_since_s = False, None
            v.disarm()
            self.copter.landed_and_disarmed()

    def _auto_disarm(self) -> None:
        v = self.copter.vehicle
        delay_s = self.copter.params.get("DISARM_DELAY")
        if not v.armed or v.in_air or delay_s <= 0:
            self._idle_since_s = None
            return
        if self._idle_since_s is None:
            self._idle_since_s = v.time_s
        elif v.time_s - self._idle_since_s >= delay_s:
            self._idle_since_s = None
            v.disarm()
            self.copter.landed_and_disarmed()
            self.copter.events.statustext(mav.MAV_SEVERITY_INFO, "Disarming motors (auto disarm)")
