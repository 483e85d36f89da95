"""One simulated multirotor: what the Flight Controller of the seed (a dRonin board on a quad)
does in the air, close enough that missions take the time they would take outside.

Commands are synchronous and vehicle-level (NED targets relative to home); refusals raise
:class:`VehicleError` with the reason. Time only moves in :meth:`SimVehicle.step`, normally called
by :class:`~dronefleet.sim.world.SimWorld` for all vehicles at once, or directly by unit tests.
"""

from __future__ import annotations

import enum
import logging
import math

from dronefleet.geo.ned import LocalFrame
from dronefleet.geo.types import LLA, NED
from dronefleet.sim.attitude import attitude, track_yaw
from dronefleet.sim.gps import GpsReceiver
from dronefleet.sim.wind import CALM, Wind
from dronefleet.vehicle.base import Attitude, BatteryState, FcError, FlightMode
from dronefleet.vehicle.battery import Battery
from dronefleet.vehicle.kinematics import FlightLimits, Kinematics

log = logging.getLogger(__name__)

#: Lowest position target above home; below that, use land().
MIN_TARGET_ALT_M = 0.5
#: How close to its home a landed vehicle must stand to get its battery swapped (``recharge_s``).
RECHARGE_RADIUS_M = 5.0
_EPS_S = 1e-9


class VehicleError(FcError):
    """A command the simulated vehicle refused; the message says why and what to do."""


class _Phase(enum.Enum):
    GROUND = "ground"
    FLYING = "flying"  # motors on, following a position target
    LANDING = "landing"
    FALLING = "falling"  # motors off in the air


class SimVehicle:
    """A quadcopter with the seed's limits, a 4S LiPo, a 5 Hz GPS, flying in (optional) wind."""

    def __init__(
        self,
        vehicle_id: str,
        home: LLA,
        *,
        max_speed_mps: float = 10.0,
        max_climb_mps: float = 2.0,
        max_descent_mps: float = 1.5,
        accel_mps2: float = 2.5,
        accel_z_mps2: float = 2.5,
        arming_s: float = 3.0,
        reboot_s: float = 2.0,
        capacity_mah: float = 5500.0,
        cell_count: int = 4,
        initial_charge_pct: float = 100.0,
        failsafe_pct: float = 5.0,
        hover_current_a: float = 18.0,
        idle_current_a: float = 0.5,
        gps_rate_hz: float = 5.0,
        gps_noise_m: float = 0.0,
        seed: int | None = None,
        wind: Wind | None = None,
        start_time_s: float = 0.0,
        recharge_s: float | None = None,
    ) -> None:
        self.vehicle_id = vehicle_id
        self._home = home
        # Its own frame: the shared cache of frames (geo.ned.local_frame) holds 256 homes, and a
        # fleet of 1000 rebuilt one for every fix it read.
        self._frame = LocalFrame(home)
        self._gps_ned: NED | None = None  # the fix _gps_lla was computed from
        self._gps_lla: LLA = home
        self.limits = FlightLimits(
            max_speed_mps, max_climb_mps, max_descent_mps, accel_mps2, accel_z_mps2
        )
        self.arming_s = arming_s
        #: Disarm as soon as a landing touches down (an autopilot may rather wait, see sim.mavlink)
        self.disarm_on_touchdown = True
        self.reboot_s = reboot_s
        self.failsafe_pct = failsafe_pct
        #: A battery swap (``dronefleet demo --recharge-s``): on the ground at home, disarmed, for
        #: this many vehicle seconds, and the pack is full again. None (the experiments): never.
        self.recharge_s = recharge_s
        self._parked_since: float | None = None
        self.battery = Battery(
            capacity_mah, cell_count, initial_charge_pct, hover_current_a, idle_current_a
        )
        self.gps = GpsReceiver(home, gps_rate_hz, gps_noise_m, seed)
        self.wind = wind or CALM
        self._t = start_time_s
        self._kin = Kinematics()
        self._phase = _Phase.GROUND
        self._target: tuple[float, float, float] | None = None
        # A velocity target (north, east, down m/s) and until when it holds (vehicle s).
        self._velocity: tuple[float, float, float, float] | None = None
        self._armed = False
        self._arming_since: float | None = None
        self._reboot_until: float | None = None
        self._mode = FlightMode.STABILIZE
        self._failsafe = False
        self._yaw_deg = 0.0
        self.gps.update(self._t, 0.0, 0.0, 0.0)

    # -- time ---------------------------------------------------------------------------------
    def step(self, dt_s: float) -> None:
        """Advance this vehicle by ``dt_s`` vehicle seconds."""
        self._t += dt_s
        if self._reboot_until is not None and self._t >= self._reboot_until - _EPS_S:
            self._reboot_until = None
            log.info("%s: reboot complete", self.vehicle_id)
        if (
            self._arming_since is not None
            and self._t - self._arming_since >= self.arming_s - _EPS_S
        ):
            self._arming_since = None
            self._armed = True
            log.info("%s: armed", self.vehicle_id)
        k, wind, phase = self._kin, self.wind, self._phase
        if phase is _Phase.FLYING and self._velocity is not None:
            *want, until = self._velocity
            if self._t >= until - _EPS_S:  # no new target in time: brake and hold there
                self._velocity, self._target = None, k.stop_point(self.limits)
            else:
                k.fly_velocity((want[0], want[1], want[2]), dt_s, self.limits, wind.n_mps,
                               wind.e_mps)  # fmt: skip
                self._target = (k.n, k.e, k.d)
            airspeed = math.hypot(k.vn - wind.n_mps, k.ve - wind.e_mps)
            current = self.battery.flight_current_a(airspeed, -k.vd, self.limits.max_speed_mps)
        elif phase is _Phase.FLYING or phase is _Phase.LANDING:
            tn, te, td = self._target  # type: ignore[misc]
            k.fly_to(tn, te, td, dt_s, self.limits, wind.n_mps, wind.e_mps)
            airspeed = math.hypot(k.vn - wind.n_mps, k.ve - wind.e_mps)
            current = self.battery.flight_current_a(airspeed, -k.vd, self.limits.max_speed_mps)
            if phase is _Phase.LANDING and k.d >= 0.0:
                self._touchdown()
        elif phase is _Phase.FALLING:
            k.fall(dt_s, wind.n_mps, wind.e_mps)
            current = self.battery.idle_current_a
            if k.d >= 0.0:
                self._phase = _Phase.GROUND
                log.warning("%s: hit the ground with the motors off", self.vehicle_id)
        else:
            current = (
                self.battery.armed_idle_current_a if self._armed else self.battery.idle_current_a
            )
        self.battery.draw(current, dt_s)
        self._check_battery()
        if self.recharge_s is not None:
            self._recharge()
        self.gps.update(self._t, k.n, k.e, k.d)
        self._yaw_deg = track_yaw(k, self._yaw_deg)

    def _touchdown(self) -> None:
        self._velocity = None
        self._kin.rest_on_ground()
        self._phase = _Phase.GROUND
        self._target = None
        if self.disarm_on_touchdown:
            self._armed = False
        log.info("%s: landed", self.vehicle_id)

    def _recharge(self) -> None:
        """Swap the battery for a full one once the vehicle has stood ``recharge_s`` at home,
        disarmed (a person on the field swaps packs; the timer starts again after each swap)."""
        k = self._kin
        parked = (
            self._phase is _Phase.GROUND
            and not self._armed
            and self._arming_since is None
            and k.n * k.n + k.e * k.e <= RECHARGE_RADIUS_M * RECHARGE_RADIUS_M
        )
        if not parked:
            self._parked_since = None
            return
        if self._parked_since is None:
            self._parked_since = self._t
        elif self._t - self._parked_since >= (self.recharge_s or 0.0) - _EPS_S:
            was = self.battery.remaining_pct
            self.battery.swap()
            self._failsafe = False
            self._parked_since = self._t
            if was < 99.0:
                log.info("%s: battery swapped at home (%.1f %% -> 100 %%)", self.vehicle_id, was)

    def _check_battery(self) -> None:
        pct = self.battery.remaining_pct
        if pct <= 0.0 and self._phase in (_Phase.FLYING, _Phase.LANDING):
            log.error("%s: battery empty in the air, motors stop", self.vehicle_id)
            self._motors_off()
        elif pct <= self.failsafe_pct and not self._failsafe and (self._armed or self.in_air):
            self._failsafe = True
            log.warning("%s: battery failsafe at %.1f %%, landing", self.vehicle_id, pct)
            if self._phase is _Phase.FLYING:
                self._begin_landing()
            elif self._phase is _Phase.GROUND:
                self._armed = False

    # -- commands -----------------------------------------------------------------------------
    def arm(self, *, at_once: bool = False) -> None:
        """Start arming; the vehicle is armed ``arming_s`` (3 s) later, or now with ``at_once``
        (an ArduPilot autopilot arms before it acknowledges the command)."""
        self._refuse_if_rebooting()
        if self._armed:
            raise VehicleError(f"{self.vehicle_id}: already armed")
        if self._arming_since is not None:
            raise VehicleError(f"{self.vehicle_id}: arming already in progress")
        if self._phase is not _Phase.GROUND:
            raise VehicleError(f"{self.vehicle_id}: cannot arm in the air")
        pct = self.battery.remaining_pct
        if pct <= self.failsafe_pct:
            raise VehicleError(
                f"{self.vehicle_id}: battery at {pct:.1f} % (failsafe at {self.failsafe_pct:g} %);"
                " charge or swap it before arming"
            )
        self._arming_since = self._t
        if at_once or self.arming_s <= 0:
            self._arming_since, self._armed = None, True

    def disarm(self, force: bool = False) -> None:
        """Disarm on the ground; in the air only with ``force`` (the motors stop, it falls)."""
        self._arming_since = None
        if not self._armed:
            return
        if self._phase in (_Phase.FLYING, _Phase.LANDING):
            if not force:
                raise VehicleError(
                    f"{self.vehicle_id}: in the air at {self.relative_alt_m:.1f} m; land first,"
                    " or force the disarm (the drone will fall)"
                )
            log.warning("%s: forced disarm in the air", self.vehicle_id)
            self._motors_off()
            return
        self._armed = False
        self._mode = FlightMode.STABILIZE

    def takeoff(self, altitude_m: float) -> None:
        """Climb vertically to ``altitude_m`` above home (in the air: change altitude here)."""
        self._refuse_unless_can_fly()
        self._check_altitude(altitude_m)
        k = self._kin
        if self._phase is _Phase.GROUND:
            self._target = (k.n, k.e, -altitude_m)
        else:
            sn, se, _ = k.stop_point(self.limits)
            self._target = (sn, se, -altitude_m)
        self._fly(FlightMode.GUIDED)

    def goto(self, target: NED) -> None:
        """Fly to ``target`` (home NED); from the ground (armed) it takes off towards it."""
        self._refuse_unless_can_fly()
        self._check_altitude(-target.d)
        self._target = (target.n, target.e, target.d)
        self._fly(FlightMode.GUIDED)

    def idle_on_ground(self) -> None:
        """Cut the climb of a take-off that has not left the ground: armed, motors idle, down.

        What ArduPilot Copter does when its GUIDED take-off is replaced by a waypoint before the
        vehicle has lifted off (see :meth:`dronefleet.sim.mavlink.copter.SimCopter.guided_target`).
        """
        if self._phase is not _Phase.FLYING:
            return
        self._kin.rest_on_ground()
        self._phase = _Phase.GROUND
        self._target = None

    def hold(self) -> None:
        """Brake and hold the position where the vehicle comes to rest."""
        if self._phase is _Phase.GROUND:
            return
        self._refuse_unless_can_fly()
        self._target = self._kin.stop_point(self.limits)
        self._fly(FlightMode.HOLD)

    def land(self) -> None:
        """Brake and descend vertically to the ground; disarms on touchdown."""
        if self._phase is _Phase.FALLING:
            raise VehicleError(f"{self.vehicle_id}: motors are off, it is falling")
        if self._phase is _Phase.GROUND:  # already down: just make it safe
            self.disarm()
            return
        if self._phase is _Phase.FLYING:
            self._begin_landing()

    def reboot(self, force: bool = False) -> None:
        """Restart the autopilot (``reboot_s``); in the air only with ``force`` (it falls)."""
        if self.in_air and self._phase is not _Phase.FALLING:
            if not force:
                raise VehicleError(f"{self.vehicle_id}: refusing to reboot in the air; land first")
            self._motors_off()
        self._armed, self._arming_since = False, None
        self._mode = FlightMode.STABILIZE
        self._reboot_until = self._t + self.reboot_s
        log.info("%s: rebooting", self.vehicle_id)

    def _fly(self, mode: FlightMode) -> None:
        self._phase = _Phase.FLYING
        self._mode = mode
        self._velocity = None  # any new target replaces a velocity target

    def fly_velocity(self, velocity: NED, for_s: float) -> None:
        """Fly at ``velocity`` (north, east, down m/s) for ``for_s`` vehicle seconds, then brake
        and hold where it stops, unless a new target comes (ArduPilot's GUID_TIMEOUT)."""
        if self._phase is not _Phase.FLYING:
            raise VehicleError(f"{self.vehicle_id}: a velocity target needs the vehicle flying")
        self._refuse_unless_can_fly()
        self._fly(FlightMode.GUIDED)
        self._velocity = (velocity.n, velocity.e, velocity.d, self._t + for_s)

    def _begin_landing(self) -> None:
        self._velocity = None
        sn, se, _ = self._kin.stop_point(self.limits)
        self._target = (sn, se, 0.0)
        self._phase = _Phase.LANDING
        self._mode = FlightMode.LAND

    def _motors_off(self) -> None:
        self._velocity = None
        self._armed, self._arming_since = False, None
        self._target = None
        self._phase = _Phase.FALLING
        self._mode = FlightMode.STABILIZE

    def _refuse_if_rebooting(self) -> None:
        if self._reboot_until is not None:
            left = self._reboot_until - self._t
            raise VehicleError(f"{self.vehicle_id}: rebooting ({left:.1f} s left); try again then")

    def _refuse_unless_can_fly(self) -> None:
        self._refuse_if_rebooting()
        if self._phase is _Phase.FALLING:
            raise VehicleError(f"{self.vehicle_id}: motors are off, it is falling")
        if not self._armed:
            if self._arming_since is not None:
                left = self.arming_s - (self._t - self._arming_since)
                raise VehicleError(f"{self.vehicle_id}: still arming ({left:.1f} s left)")
            raise VehicleError(f"{self.vehicle_id}: not armed; arm it first")
        if self._failsafe and self._phase is _Phase.LANDING:
            raise VehicleError(
                f"{self.vehicle_id}: battery failsafe, landing"
                f" (battery {self.battery.remaining_pct:.1f} %)"
            )

    def _check_altitude(self, altitude_m: float) -> None:
        if not altitude_m >= MIN_TARGET_ALT_M:
            raise VehicleError(
                f"{self.vehicle_id}: target altitude {altitude_m:.1f} m above home is below the"
                f" {MIN_TARGET_ALT_M} m minimum; use land() to go down"
            )

    # -- state --------------------------------------------------------------------------------
    @property
    def time_s(self) -> float:
        return self._t

    @property
    def home(self) -> LLA:
        return self._home

    @property
    def position_ned(self) -> NED:
        k = self._kin
        return NED(k.n, k.e, k.d)

    @property
    def velocity_ned(self) -> NED:
        k = self._kin
        return NED(k.vn, k.ve, k.vd)

    @property
    def acceleration_ned(self) -> NED:
        k = self._kin
        return NED(k.an, k.ae, k.ad)

    @property
    def relative_alt_m(self) -> float:
        return -self._kin.d

    @property
    def position_lla(self) -> LLA:
        """The true position (the GPS fix is :attr:`gps_lla`)."""
        return self._frame.to_lla(self.position_ned)

    @property
    def gps_lla(self) -> LLA:
        """The latest GPS fix (what ``gps.fix_lla`` gives, in this vehicle's own frame)."""
        fix = self.gps.fix_ned
        if fix is not self._gps_ned:
            self._gps_lla, self._gps_ned = self._frame.to_lla(fix), fix
        return self._gps_lla

    def telemetry_sample(self) -> dict[str, float]:
        """What :func:`dronefleet.vehicle.base.telemetry_sample` gives for this vehicle's flight
        controller, read straight from its state: the same figures without a dozen objects made
        per sample (a fleet of 1000 reads 5000 a second)."""
        fix, k, att, battery = self.gps_lla, self._kin, self.attitude, self.battery
        return {
            "vehicle_time_s": self._t,
            "lat": fix.lat,
            "lon": fix.lon,
            "alt_m": fix.alt_m,
            "relative_alt_m": fix.alt_m - self._home.alt_m,
            "vn": k.vn,
            "ve": k.ve,
            "vd": k.vd,
            "roll_deg": att.roll_deg,
            "pitch_deg": att.pitch_deg,
            "yaw_deg": att.yaw_deg,
            "battery_pct": battery.remaining_pct,
            "voltage_v": battery.voltage_v,
            "current_a": battery.current_a,
            "armed": float(self._armed),
            "in_air": float(self._phase is not _Phase.GROUND),
        }

    @property
    def target_ned(self) -> NED | None:
        return None if self._target is None else NED(*self._target)

    @property
    def armed(self) -> bool:
        return self._armed

    @property
    def arming(self) -> bool:
        return self._arming_since is not None

    @property
    def rebooting(self) -> bool:
        return self._reboot_until is not None

    @property
    def in_air(self) -> bool:
        return self._phase is not _Phase.GROUND

    @property
    def landing(self) -> bool:
        return self._phase is _Phase.LANDING

    @property
    def falling(self) -> bool:
        return self._phase is _Phase.FALLING

    @property
    def battery_failsafe(self) -> bool:
        return self._failsafe

    @property
    def mode(self) -> FlightMode:
        return self._mode

    @property
    def battery_state(self) -> BatteryState:
        return self.battery.state()

    @property
    def attitude(self) -> Attitude:
        """Tilt a multirotor needs for its acceleration plus drag; yaw follows the track
        (sim/attitude.py)."""
        thrusting = self._phase is _Phase.FLYING or self._phase is _Phase.LANDING
        return attitude(self._kin, self._yaw_deg, self.wind, thrusting)

    def __repr__(self) -> str:
        k = self._kin
        return (
            f"SimVehicle({self.vehicle_id!r}, t={self._t:.2f}s, ned=({k.n:.1f}, {k.e:.1f},"
            f" {k.d:.1f}), {self._phase.value}, armed={self._armed})"
        )
