"""One simulated multirotor: what the Flight Controller of the seed (a dRonin board on a quad)
does in the air, close enough that missions take the time they would take outside.

Commands are synchronous and vehicle-level (NED targets relative to home); refusals raise
:class:`VehicleError` with the reason. Time only moves in :meth:`SimVehicle.step`, normally called
by :class:`~dronefleet.sim.world.SimWorld` for all vehicles at once, or directly by unit tests.
The commands and the flight phase are in sim/vehicle_commands.py.
"""

from __future__ import annotations

import logging
import math

from dronefleet.geo.ned import LocalFrame
from dronefleet.geo.types import LLA, NED
from dronefleet.sim.attitude import attitude, track_yaw
from dronefleet.sim.gps import GpsReceiver
from dronefleet.sim.vehicle_commands import (
    MIN_TARGET_ALT_M,
    FlightPhase,
    VehicleCommands,
    VehicleError,
)
from dronefleet.sim.wind import CALM, Wind
from dronefleet.vehicle.base import Attitude, BatteryState, FlightMode
from dronefleet.vehicle.battery import Battery
from dronefleet.vehicle.kinematics import FlightLimits, Kinematics

log = logging.getLogger(__name__)

__all__ = ["MIN_TARGET_ALT_M", "RECHARGE_RADIUS_M", "SimVehicle", "VehicleError"]

#: How close to its home a landed vehicle must stand to get its battery swapped (``recharge_s``).
RECHARGE_RADIUS_M = 5.0
_EPS_S = 1e-9


class SimVehicle(VehicleCommands):
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
        self._phase = FlightPhase.GROUND
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
        if phase is FlightPhase.FLYING and self._velocity is not None:
            *want, until = self._velocity
            if self._t >= until - _EPS_S:  # no new target in time: brake and hold there
                self._velocity, self._target = None, k.stop_point(self.limits)
            else:
                k.fly_velocity((want[0], want[1], want[2]), dt_s, self.limits, wind.n_mps,
                               wind.e_mps)  # fmt: skip
                self._target = (k.n, k.e, k.d)
            airspeed = math.hypot(k.vn - wind.n_mps, k.ve - wind.e_mps)
            current = self.battery.flight_current_a(airspeed, -k.vd, self.limits.max_speed_mps)
        elif phase is FlightPhase.FLYING or phase is FlightPhase.LANDING:
            tn, te, td = self._target  # type: ignore[misc]
            k.fly_to(tn, te, td, dt_s, self.limits, wind.n_mps, wind.e_mps)
            airspeed = math.hypot(k.vn - wind.n_mps, k.ve - wind.e_mps)
            current = self.battery.flight_current_a(airspeed, -k.vd, self.limits.max_speed_mps)
            if phase is FlightPhase.LANDING and k.d >= 0.0:
                self._touchdown()
        elif phase is FlightPhase.FALLING:
            k.fall(dt_s, wind.n_mps, wind.e_mps)
            current = self.battery.idle_current_a
            if k.d >= 0.0:
                self._phase = FlightPhase.GROUND
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
        self._phase = FlightPhase.GROUND
        self._target = None
        if self.disarm_on_touchdown:
            self._armed = False
        log.info("%s: landed", self.vehicle_id)

    def _recharge(self) -> None:
        """Swap the battery for a full one once the vehicle has stood ``recharge_s`` at home,
        disarmed (a person on the field swaps packs; the timer starts again after each swap)."""
        k = self._kin
        parked = (
            self._phase is FlightPhase.GROUND
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
        if pct <= 0.0 and self._phase in (FlightPhase.FLYING, FlightPhase.LANDING):
            log.error("%s: battery empty in the air, motors stop", self.vehicle_id)
            self._motors_off()
        elif pct <= self.failsafe_pct and not self._failsafe and (self._armed or self.in_air):
            self._failsafe = True
            log.warning("%s: battery failsafe at %.1f %%, landing", self.vehicle_id, pct)
            if self._phase is FlightPhase.FLYING:
                self._begin_landing()
            elif self._phase is FlightPhase.GROUND:
                self._armed = False

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
            "in_air": float(self._phase is not FlightPhase.GROUND),
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
        return self._phase is not FlightPhase.GROUND

    @property
    def landing(self) -> bool:
        return self._phase is FlightPhase.LANDING

    @property
    def falling(self) -> bool:
        return self._phase is FlightPhase.FALLING

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
        thrusting = self._phase is FlightPhase.FLYING or self._phase is FlightPhase.LANDING
        return attitude(self._kin, self._yaw_deg, self.wind, thrusting)

    def __repr__(self) -> str:
        k = self._kin
        return (
            f"SimVehicle({self.vehicle_id!r}, t={self._t:.2f}s, ned=({k.n:.1f}, {k.e:.1f},"
            f" {k.d:.1f}), {self._phase.value}, armed={self._armed})"
        )
