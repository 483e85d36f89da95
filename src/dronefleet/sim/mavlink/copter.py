"""ArduPilot Copter's flight modes on a simulated vehicle: what our MAVLink endpoint flies.

The :class:`~dronefleet.sim.vehicle.SimVehicle` knows targets, arming and landing; this layer adds
what an ArduPilot Copter does on top (the autopilot of the seed's Flight Controller, now over
MAVLink, seed 6.2.4): mode numbers and which commands each mode accepts (takeoff only in GUIDED
and armed, position targets only in GUIDED, no arming in AUTO/RTL/LAND), RTL (climb to RTL_ALT,
fly home, land), BRAKE/LOITER holds, the battery failsafe's switch to LAND, the GCS failsafe
(:meth:`SimCopter.gcs_failsafe_check`, as ``ArduCopter/events.cpp`` does it: FS_GCS_ENABLE,
FS_GCS_TIMEOUT, FS_OPTIONS), and AUTO, which flies the mission on board (:mod:`.auto`) whether or
not anyone is listening. Refusals raise
:class:`CommandRefused` with the text the endpoint sends as STATUSTEXT before the COMMAND_ACK.

What ArduPilot does that a forgiving simulator would not (issue 17; ArduPilot upstream 64a9c78):
- a GUIDED position target while the vehicle is still on the ground replaces the take-off with a
  waypoint, whose controller keeps the motors idle while landed (ArduCopter/mode_guided.cpp,
  ``ModeGuided::set_destination`` and ``wp_control_run``): the vehicle stays down;
- armed, on the ground and idle for DISARM_DELAY seconds, it disarms
  (ArduCopter/motors.cpp, ``Copter::auto_disarm_check``); a landing disarms once the land
  detector says landed (:mod:`.landing`);
- AUTO on the ground does not start the mission until MISSION_START (``auto_armed``);
- a landing descends at LAND_SPEED_HIGH or WPNAV_SPEED_DN down to LAND_ALT_LOW, then at
  LAND_SPEED (``get_land_descent_speed``), so 10 m take ~20 s (:mod:`.landing`).
"""

from __future__ import annotations

import logging
from dataclasses import replace
from typing import Any

from dronefleet.errors import Conflict
from dronefleet.geo.types import NED
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.items import MissionItem
from dronefleet.protocols.mavlink.modes import CopterMode
from dronefleet.sim.camera import SimCamera
from dronefleet.sim.mavlink.auto import MissionRunner
from dronefleet.sim.mavlink.health import prearm_failure
from dronefleet.sim.mavlink.landing import Landing
from dronefleet.sim.mavlink.params import ParamTable
from dronefleet.sim.mavlink.trigger import DistanceTrigger
from dronefleet.sim.vehicle import SimVehicle, VehicleError

log = logging.getLogger(__name__)

#: Below this height a take-off has not left the ground for ArduPilot's land detector (m).
_LIFTOFF_M = 0.3
#: Modes ArduPilot refuses to arm in (Mode::allows_arming()).
_NOT_ARMABLE = {CopterMode.AUTO, CopterMode.RTL, CopterMode.SMART_RTL, CopterMode.LAND}
#: Modes that hold position in the air without pilot input here (no RC in the sim).
_HOLDING = {
    CopterMode.STABILIZE, CopterMode.ALT_HOLD, CopterMode.LOITER, CopterMode.POSHOLD,
    CopterMode.BRAKE, CopterMode.ACRO, CopterMode.SPORT, CopterMode.CIRCLE,
}  # fmt: skip
_ARRIVED_M = 1.0


class CommandRefused(Conflict):
    """A command the autopilot refuses; ``reason`` goes out as STATUSTEXT (None: silent)."""

    def __init__(self, reason: str | None, result: int = mav.MAV_RESULT_FAILED) -> None:
        super().__init__(reason or "refused")
        self.reason = reason
        self.result = result


class CopterEvents:
    """What the copter tells the ground; the endpoint overrides these to send messages."""

    def statustext(self, severity: int, text: str) -> None:
        log.info("copter says: %s", text)

    def mission_current(self, seq: int) -> None: ...

    def item_reached(self, seq: int) -> None: ...

    def captured(self, info: dict[str, Any]) -> None: ...


class SimCopter:
    """One simulated ArduPilot Copter: mode logic over a :class:`SimVehicle`."""

    def __init__(
        self,
        vehicle: SimVehicle,
        *,
        camera: SimCamera | None = None,
        params: ParamTable | None = None,
        events: CopterEvents | None = None,
    ) -> None:
        self.vehicle = vehicle
        self.camera = camera
        self.params = params or ParamTable()
        self.params.on_change(self._param_changed)
        if camera is not None:  # a camera the autopilot triggers (CAM1_TYPE 1, servo)
            self.params.set("CAM1_TYPE", 1)
        self.events = events or CopterEvents()
        self.mode = CopterMode.STABILIZE
        self.mission: list[MissionItem] = []
        self.runner = MissionRunner(self)
        self.trigger = DistanceTrigger(self.take_picture)
        self.boot_epoch_s = vehicle.time_s
        self._rtl_phase: str | None = None
        self._rtl_alt_m = 0.0
        self._failsafe_noted = False
        self._was_rebooting = False
        self.picture_count = 0
        #: Vehicle time of the last HEARTBEAT from the ground station SYSID_MYGCS (None: never).
        self.gcs_last_seen_s: float | None = None
        self.gcs_failsafe = False  # in GCS failsafe now
        self.auto_armed = False  # AUTO may fly its mission (MISSION_START, or AUTO in the air)
        self.landing = Landing(self)
        #: The last pre-arm checks' result (ArduPilot runs them while disarmed, at 1 Hz).
        self.prearm_passed = prearm_failure(self) is None

    # -- time ---------------------------------------------------------------------------------
    def boot_ms(self) -> int:
        return max(0, int((self.vehicle.time_s - self.boot_epoch_s) * 1000))

    # -- modes --------------------------------------------------------------------------------
    def set_mode(self, number: int) -> None:
        try:
            mode = CopterMode(number)
        except ValueError:
            raise CommandRefused(f"Mode change failed: no mode {number}") from None
        v = self.vehicle
        if mode is CopterMode.AUTO and len(self.mission) <= 1:
            raise CommandRefused("Mode change to AUTO failed: no mission")
        if mode is CopterMode.GUIDED_NOGPS or mode is CopterMode.THROW:
            raise CommandRefused(f"Mode change to {mode.name} failed: not supported by the sim")
        self._leave_mode()
        self.mode = mode
        if not v.in_air or v.falling:
            return  # AUTO on the ground waits for MISSION_START
        if mode is CopterMode.LAND:
            v.land()
        elif mode in (CopterMode.RTL, CopterMode.SMART_RTL):
            self.start_rtl()
        elif mode is CopterMode.AUTO:
            self.auto_armed = True
            self.runner.start()
        else:  # GUIDED starts by holding where it is, like the hold modes
            v.hold()

    def set_speed(self, speed_mps: float) -> None:
        """DO_CHANGE_SPEED: the horizontal speed until the mode changes (ArduPilot sets the
        waypoint controller's speed, not WPNAV_SPEED, so it does not carry into the next mode)."""
        if speed_mps > 0:
            self.vehicle.limits = replace(self.vehicle.limits, max_speed_mps=speed_mps)

    def _leave_mode(self) -> None:
        # A speed changed for this mode (DO_CHANGE_SPEED) ends with it (issue 10, item 7).
        self._param_changed("WPNAV_SPEED", self.params.get("WPNAV_SPEED"))
        self.runner.stop()
        self._rtl_phase = None
        self.auto_armed = False

    def start_mission(self) -> None:
        """MISSION_START: AUTO, and fly (or resume) the mission (must be armed)."""
        if not self.vehicle.armed:
            raise CommandRefused("Mission: arm first")
        self.set_mode(CopterMode.AUTO)
        self.auto_armed = True
        if not self.runner.running:
            self.runner.finished = False
            self.runner.start()

    # -- commands -----------------------------------------------------------------------------
    def arm(self, force: bool = False) -> None:
        """Arm now, as ArduPilot does (AP_Arming::arm runs inside the command handler, so the
        COMMAND_ACK goes out armed); the SimVehicle's own arming delay (3 s, the seed's Flight
        Controller) would fail a takeoff sent right after the ACK (issue 10, item 1)."""
        v = self.vehicle
        if v.armed:
            return
        if self.mode in _NOT_ARMABLE and not force:
            raise CommandRefused("Arm: Mode not armable")
        try:
            v.arm(at_once=True)
        except VehicleError as exc:
            raise CommandRefused("Arm: " + _reason(exc, v)) from None

    def disarm(self, force: bool = False) -> None:
        try:
            self.vehicle.disarm(force=force)
        except VehicleError as exc:
            raise CommandRefused("Disarm: " + _reason(exc, self.vehicle)) from None
        if not self.vehicle.in_air or force:
            self._leave_mode()

    def takeoff(self, altitude_m: float) -> None:
        v = self.vehicle
        if self.mode is not CopterMode.GUIDED:
            raise CommandRefused(f"Takeoff: not in GUIDED mode (in {self.mode.name})")
        if not v.armed:
            raise CommandRefused("Takeoff: not armed")
        if v.in_air:
            raise CommandRefused("Takeoff: already flying")
        try:
            v.takeoff(altitude_m)
        except VehicleError as exc:
            raise CommandRefused("Takeoff: " + _reason(exc, v)) from None

    def guided_target(self, target: NED) -> None:
        v = self.vehicle
        if self.mode is not CopterMode.GUIDED:
            raise CommandRefused(f"Guided: not in GUIDED mode (in {self.mode.name})")
        if not v.in_air or v.relative_alt_m < _LIFTOFF_M:
            v.idle_on_ground()  # accepted, and the vehicle stays down (see the module doc)
            return
        try:
            v.goto(target)
        except VehicleError as exc:
            raise CommandRefused("Guided: " + _reason(exc, v)) from None

    def guided_velocity(self, velocity: NED) -> None:
        """A GUIDED velocity target: flown for GUID_TIMEOUT seconds unless renewed, then the
        vehicle brakes and holds (ArduCopter/mode_guided.cpp's velocity timeout)."""
        v = self.vehicle
        if self.mode is not CopterMode.GUIDED:
            raise CommandRefused(f"Guided: not in GUIDED mode (in {self.mode.name})")
        if not v.in_air or v.relative_alt_m < _LIFTOFF_M:
            raise CommandRefused("Guided: take off before a velocity target")
        try:
            v.fly_velocity(velocity, float(self.params.get("GUID_TIMEOUT")))
        except VehicleError as exc:
            raise CommandRefused("Guided: " + _reason(exc, v)) from None

    def reboot(self, force: bool) -> None:
        v = self.vehicle
        if v.armed and not force:
            raise CommandRefused("Reboot: vehicle is armed; disarm first")
        self._leave_mode()
        self.mode = CopterMode.STABILIZE
        self.gcs_last_seen_s, self.gcs_failsafe = None, False  # a new boot has heard nobody
        v.reboot(force=True)

    def take_picture(self) -> dict[str, Any] | None:
        if self.camera is None:
            return None
        info = self.camera.capture()
        self.picture_count = self.camera.count
        self.trigger.shot_at(self.vehicle.position_ned)
        self.events.captured(info)
        return info

    # -- RTL ----------------------------------------------------------------------------------
    def start_rtl(self) -> None:
        """Climb to RTL_ALT (if lower), fly home, land (Copter's RTL)."""
        v = self.vehicle
        self._rtl_alt_m = max(self.params.get("RTL_ALT") / 100.0, v.relative_alt_m)
        here = v.position_ned
        v.goto(NED(here.n, here.e, -self._rtl_alt_m))
        self._rtl_phase = "climb"

    def _rtl_step(self) -> bool:
        """Advance RTL; True once landed."""
        v = self.vehicle
        if not v.in_air:
            self._rtl_phase = None
            return True
        target = v.target_ned
        arrived = target is not None and (target - v.position_ned).norm_m < _ARRIVED_M
        if self._rtl_phase == "climb" and arrived:
            v.goto(NED(0.0, 0.0, -self._rtl_alt_m))
            self._rtl_phase = "return"
        elif self._rtl_phase == "return" and arrived:
            v.land()
            self._rtl_phase = "land"
        return False

    # -- the loop -----------------------------------------------------------------------------
    def update(self) -> None:
        """One look at the vehicle (called every physics step or so by the endpoint)."""
        v = self.vehicle
        if v.rebooting:
            self._was_rebooting = True
            return
        if self._was_rebooting:  # back from a reboot: time_boot_ms starts again at zero
            self._was_rebooting = False
            self.boot_epoch_s = v.time_s
        if v.battery_failsafe and not self._failsafe_noted:
            self._failsafe_noted = True
            pct = v.battery_state.remaining_pct
            self.events.statustext(mav.MAV_SEVERITY_CRITICAL, f"Battery failsafe {pct:.0f}%: LAND")
            if v.landing and self.mode is not CopterMode.LAND:
                self._leave_mode()
                self.mode = CopterMode.LAND
        self.gcs_failsafe_check()
        if self._rtl_phase is not None and self.mode in (CopterMode.RTL, CopterMode.SMART_RTL):
            self._rtl_step()
        elif self.mode is CopterMode.AUTO:
            if v.armed and self.auto_armed and not self.runner.running and not self.runner.finished:
                self.runner.start()
            self.runner.update()
        if not v.armed:
            self.prearm_passed = prearm_failure(self) is None
        if self.camera is not None and v.armed:
            self.trigger.update(v.position_ned)
        self.landing.update()

    # -- the GCS failsafe (ArduCopter/events.cpp) ---------------------------------------------
    def gcs_heard(self) -> None:
        """A HEARTBEAT from our ground station (SYSID_MYGCS) arrived."""
        self.gcs_last_seen_s = self.vehicle.time_s

    def gcs_failsafe_check(self) -> None:
        """``Copter::failsafe_gcs_check``: off when FS_GCS_ENABLE is 0 or no ground station was
        ever heard; on after FS_GCS_TIMEOUT vehicle seconds without one (once per outage),
        cleared when it is heard again (the mode it chose stays)."""
        if not self.params.get("FS_GCS_ENABLE") or self.gcs_last_seen_s is None:
            return
        silent_s = self.vehicle.time_s - self.gcs_last_seen_s
        timeout_s = max(0.0, float(self.params.get("FS_GCS_TIMEOUT")))
        if silent_s < timeout_s and self.gcs_failsafe:
            self.gcs_failsafe = False
            self.events.statustext(mav.MAV_SEVERITY_WARNING, "GCS Failsafe Cleared")
        elif silent_s > timeout_s and not self.gcs_failsafe:
            self.gcs_failsafe = True
            self._gcs_failsafe_on()

    def _gcs_failsafe_on(self) -> None:
        """``Copter::failsafe_gcs_on_event``: FS_GCS_ENABLE's action, unless disarmed (only
        said), landed (disarm), landing for the battery failsafe or with FS_OPTIONS bit 3
        (landing goes on), or in AUTO with FS_OPTIONS bit 1 (the mission goes on)."""
        v, options = self.vehicle, int(self.params.get("FS_OPTIONS"))
        enable = int(self.params.get("FS_GCS_ENABLE"))
        landing = self.mode is CopterMode.LAND or v.landing or self._rtl_phase == "land"
        say = "GCS Failsafe"
        action: CopterMode | None = {
            5: CopterMode.LAND, 7: CopterMode.LAND, 3: CopterMode.SMART_RTL,
            4: CopterMode.SMART_RTL,
        }.get(enable, CopterMode.RTL)  # fmt: skip
        if not v.armed:
            action = None
        elif not v.in_air:
            say, action = "GCS Failsafe - Disarming", None
            self.disarm(force=True)
        elif landing and v.battery_failsafe:
            say, action = "GCS + Battery Failsafe - Continuing Landing", None
        elif landing and options & 8:
            say, action = "GCS Failsafe - Continuing Landing", None
        elif self.mode is CopterMode.AUTO and options & 2:
            say, action = "GCS Failsafe - Continuing Auto Mode", None
        self.events.statustext(mav.MAV_SEVERITY_WARNING, say)
        if action is not None and action is not self.mode:
            self.set_mode(action)

    def landed_and_disarmed(self) -> None:
        """Disarmed on the ground by the land detector or DISARM_DELAY (:mod:`.landing`)."""
        self._leave_mode()

    def rtl_step_for_mission(self) -> bool:
        """RTL as a mission item (the runner calls this): True once landed."""
        if self._rtl_phase is None:
            if not self.vehicle.in_air:
                return True
            self.start_rtl()
        return self._rtl_step()

    def _param_changed(self, name: str, value: float) -> None:
        v = self.vehicle
        limits = v.limits
        if name == "WPNAV_SPEED" and value > 0:
            v.limits = replace(limits, max_speed_mps=value / 100.0)
        elif name == "WPNAV_SPEED_UP" and value > 0:
            v.limits = replace(limits, max_climb_mps=value / 100.0)
        elif name == "WPNAV_SPEED_DN" and value > 0:
            v.limits = replace(limits, max_descent_mps=value / 100.0)
        elif name == "WPNAV_ACCEL" and value > 0:
            v.limits = replace(limits, accel_mps2=value / 100.0)

    def on_mission_replaced(self, items: list[MissionItem]) -> None:
        self.mission = items
        self.runner.reset()


def _reason(exc: Exception, vehicle: SimVehicle) -> str:
    """The vehicle's refusal without its id prefix (the ground knows which vehicle it asked)."""
    text = str(exc)
    prefix = f"{vehicle.vehicle_id}: "
    return text[len(prefix) :] if text.startswith(prefix) else text
