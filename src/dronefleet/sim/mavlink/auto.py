"""AUTO mode: the simulated Copter flies its uploaded mission on board.

As ArduPilot does: the mission starts at item 1 (item 0 is home); a NAV command (take off, fly to a
waypoint, loiter for a time, land, return to launch) runs until it completes, and the DO commands
after it (take a picture, trigger the camera by distance, change speed) run when it *completes*,
before the next NAV command starts — ``AP_Mission::advance_current_nav_cmd`` starts the DO commands
it passes on its way to the next NAV command; DO commands before the first NAV command run at the
start. DO_JUMP repeats a section. A waypoint counts as reached inside WPNAV_RADIUS;
MISSION_ITEM_REACHED goes out then, before any hold time. Nothing here needs a ground station: the
vehicle keeps flying the mission when the link is gone, which is the point of uploading it.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import LLA, NED
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.items import ABSOLUTE, MissionItem
from dronefleet.sim.vehicle import MIN_TARGET_ALT_M, VehicleError

if TYPE_CHECKING:
    from dronefleet.sim.mavlink.copter import SimCopter

#: A takeoff is complete this close to its altitude (metres).
_TAKEOFF_DONE_M = 0.5


class MissionRunner:
    """Steps through ``copter.mission``; :meth:`update` is called every physics step or so."""

    def __init__(self, copter: SimCopter) -> None:
        self.copter = copter
        self.current = 0
        self.running = False
        self.finished = False
        self._phase = "idle"  # go | hold | land | rtl | takeoff
        self._hold_until = 0.0
        self._jumps: dict[int, int] = {}

    @property
    def items(self) -> list[MissionItem]:
        return self.copter.mission

    def reset(self) -> None:
        self.stop()
        self.current = 0
        self.finished = False
        self._jumps.clear()

    def set_current(self, seq: int) -> None:
        self.current = seq
        self.finished = False
        if self.running:
            self._begin(seq)
        self.copter.events.mission_current(seq)

    def start(self, seq: int | None = None) -> None:
        if seq is None:
            seq = self.current if self.current >= 1 and not self.finished else 1
        self.running, self.finished = True, False
        self._jumps.clear()
        self._begin(max(1, seq))

    def stop(self) -> None:
        self.running = False
        self._phase = "idle"

    # -- stepping -----------------------------------------------------------------------------
    def _begin(self, seq: int) -> None:
        seq = self._skip_to_nav(seq)
        if seq >= len(self.items):
            self._finish()
            return
        self.current = seq
        self.copter.events.mission_current(seq)
        self._start_nav(self.items[seq])

    def _skip_to_nav(self, seq: int) -> int:
        """From ``seq``, the next NAV item, following DO_JUMPs that still have repeats left and
        running the DO commands passed on the way."""
        guard = 0
        while seq < len(self.items) and not self.items[seq].is_nav and guard < 1000:
            guard += 1
            item = self.items[seq]
            if item.command == mav.MAV_CMD_DO_JUMP:
                left = self._jumps.setdefault(seq, int(item.param2))
                if left != 0:
                    self._jumps[seq] = left - 1 if left > 0 else -1
                    seq = int(item.param1)
                    continue
            else:
                self._run_do(item)
            seq += 1
        return seq

    def _advance(self) -> None:
        self._begin(self.current + 1)

    def _finish(self) -> None:
        self.running, self.finished = False, True
        self._phase = "idle"
        v = self.copter.vehicle
        if v.in_air and not v.landing:
            v.hold()  # Copter loiters at the last waypoint when the mission ends in the air
        self.copter.events.statustext(mav.MAV_SEVERITY_INFO, "Mission complete")

    def _start_nav(self, item: MissionItem) -> None:
        v = self.copter.vehicle
        cmd = item.command
        try:
            if cmd == mav.MAV_CMD_NAV_TAKEOFF:
                self._phase = "takeoff"
                if v.armed:  # not armed yet: update() takes off once it is
                    v.takeoff(max(item.z, MIN_TARGET_ALT_M))
            elif cmd in (mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_CMD_NAV_LOITER_TIME):
                self._phase = "go"
                v.goto(self._target(item))
            elif cmd in (mav.MAV_CMD_NAV_LOITER_UNLIM, mav.MAV_CMD_NAV_DELAY):
                self._phase = "hold"
                self._hold_until = (
                    float("inf") if cmd == mav.MAV_CMD_NAV_LOITER_UNLIM else v.time_s + item.param1
                )
                v.hold()
            elif cmd == mav.MAV_CMD_NAV_LAND:
                if item.x or item.y:
                    here = v.position_ned
                    self._phase = "go_land"
                    target = self._target(item)
                    v.goto(NED(target.n, target.e, here.d))
                else:
                    self._phase = "land"
                    v.land()
            elif cmd == mav.MAV_CMD_NAV_RETURN_TO_LAUNCH:
                self._phase = "rtl"
        except VehicleError as exc:
            self.copter.events.statustext(mav.MAV_SEVERITY_WARNING, f"Mission: {exc}")

    def _target(self, item: MissionItem) -> NED:
        v = self.copter.vehicle
        home = v.home
        here = v.position_ned
        alt = item.z - home.alt_m if item.frame == ABSOLUTE else item.z
        if item.x == 0 and item.y == 0:
            return NED(here.n, here.e, -max(alt, MIN_TARGET_ALT_M))
        ned = lla_to_ned(LLA(item.lat, item.lon, home.alt_m), home)
        return NED(ned.n, ned.e, -max(alt, MIN_TARGET_ALT_M))

    def _run_do(self, item: MissionItem) -> None:
        v = self.copter.vehicle
        cmd = item.command
        shoot = cmd == mav.MAV_CMD_DO_DIGICAM_CONTROL and item.x == 1
        if shoot or cmd == mav.MAV_CMD_IMAGE_START_CAPTURE:
            self.copter.take_picture()
        elif cmd == mav.MAV_CMD_DO_SET_CAM_TRIGG_DIST:
            self.copter.trigger.set_distance(item.param1, shoot_now=item.param3 == 1)
        elif cmd == mav.MAV_CMD_DO_CHANGE_SPEED and item.param2 > 0:
            v.limits = replace(v.limits, max_speed_mps=item.param2)

    def update(self) -> None:
        if not self.running:
            return
        v = self.copter.vehicle
        item = self.items[self.current] if self.current < len(self.items) else None
        if item is None:
            self._finish()
            return
        phase = self._phase
        if phase == "takeoff":
            if not v.in_air and v.armed and v.target_ned is None:
                v.takeoff(max(item.z, MIN_TARGET_ALT_M))  # armed after the mission started
            if v.in_air and abs(v.relative_alt_m - item.z) < _TAKEOFF_DONE_M:
                self._reached(item, 0.0)
        elif phase in ("go", "go_land"):
            target = v.target_ned
            radius = self.copter.params.get("WPNAV_RADIUS") / 100.0
            if target is not None and (target - v.position_ned).norm_m < radius:
                if phase == "go_land":
                    self._phase = "land"
                    v.land()
                else:
                    self._reached(item, item.param1)
        elif phase == "hold":
            if v.time_s >= self._hold_until:
                self._advance()
        elif phase == "land":
            if not v.in_air:
                self._reached(item, 0.0)
        elif phase == "rtl" and self.copter.rtl_step_for_mission():
            self._reached(item, 0.0)

    def _reached(self, item: MissionItem, hold_s: float) -> None:
        self.copter.events.item_reached(self.current)
        if hold_s > 0:
            self._phase = "hold"
            self._hold_until = self.copter.vehicle.time_s + hold_s
        else:
            self._advance()
