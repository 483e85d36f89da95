"""The commands of a simulated vehicle and its flight phase: arm, disarm, take off, go to, hold,
land, reboot and fly at a velocity, each refused with a :class:`VehicleError` that says why, and
the phase changes they make (flying, landing, motors off).

:class:`VehicleCommands` is a base of :class:`~dronefleet.sim.vehicle.SimVehicle`, which holds the
state the commands read and change and moves time (``SimVehicle.step``).
"""

from __future__ import annotations

import enum
import logging
from typing import TYPE_CHECKING

from dronefleet.geo.types import NED
from dronefleet.vehicle.base import FcError, FlightMode
from dronefleet.vehicle.battery import Battery
from dronefleet.vehicle.kinematics import FlightLimits, Kinematics

# The vehicle's own logger: these messages came from sim/vehicle.py before the split.
log = logging.getLogger("dronefleet.sim.vehicle")

#: Lowest position target above home; below that, use land().
MIN_TARGET_ALT_M = 0.5


class VehicleError(FcError):
    """A command the simulated vehicle refused; the message says why and what to do."""


class FlightPhase(enum.Enum):
    GROUND = "ground"
    FLYING = "flying"  # motors on, following a position target
    LANDING = "landing"
    FALLING = "falling"  # motors off in the air


class VehicleCommands:
    """The commands of :class:`~dronefleet.sim.vehicle.SimVehicle` (synchronous, vehicle-level:
    NED targets relative to home)."""

    # The vehicle's state, set up by SimVehicle.__init__.
    vehicle_id: str
    limits: FlightLimits
    battery: Battery
    arming_s: float
    reboot_s: float
    failsafe_pct: float
    _t: float
    _kin: Kinematics
    _phase: FlightPhase
    _target: tuple[float, float, float] | None
    _velocity: tuple[float, float, float, float] | None
    _armed: bool
    _arming_since: float | None
    _reboot_until: float | None
    _mode: FlightMode
    _failsafe: bool

    if TYPE_CHECKING:  # SimVehicle's properties

        @property
        def relative_alt_m(self) -> float: ...

        @property
        def in_air(self) -> bool: ...

    def arm(self, *, at_once: bool = False) -> None:
        """Start arming; the vehicle is armed ``arming_s`` (3 s) later, or now with ``at_once``
        (an ArduPilot autopilot arms before it acknowledges the command)."""
        self._refuse_if_rebooting()
        if self._armed:
            raise VehicleError(f"{self.vehicle_id}: already armed")
        if self._arming_since is not None:
            raise VehicleError(f"{self.vehicle_id}: arming already in progress")
        if self._phase is not FlightPhase.GROUND:
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
        if self._phase in (FlightPhase.FLYING, FlightPhase.LANDING):
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
        if self._phase is FlightPhase.GROUND:
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
        if self._phase is not FlightPhase.FLYING:
            return
        self._kin.rest_on_ground()
        self._phase = FlightPhase.GROUND
        self._target = None

    def hold(self) -> None:
        """Brake and hold the position where the vehicle comes to rest."""
        if self._phase is FlightPhase.GROUND:
            return
        self._refuse_unless_can_fly()
        self._target = self._kin.stop_point(self.limits)
        self._fly(FlightMode.HOLD)

    def land(self) -> None:
        """Brake and descend vertically to the ground; disarms on touchdown."""
        if self._phase is FlightPhase.FALLING:
            raise VehicleError(f"{self.vehicle_id}: motors are off, it is falling")
        if self._phase is FlightPhase.GROUND:  # already down: just make it safe
            self.disarm()
            return
        if self._phase is FlightPhase.FLYING:
            self._begin_landing()

    def reboot(self, force: bool = False) -> None:
        """Restart the autopilot (``reboot_s``); in the air only with ``force`` (it falls)."""
        if self.in_air and self._phase is not FlightPhase.FALLING:
            if not force:
                raise VehicleError(f"{self.vehicle_id}: refusing to reboot in the air; land first")
            self._motors_off()
        self._armed, self._arming_since = False, None
        self._mode = FlightMode.STABILIZE
        self._reboot_until = self._t + self.reboot_s
        log.info("%s: rebooting", self.vehicle_id)

    def _fly(self, mode: FlightMode) -> None:
        self._phase = FlightPhase.FLYING
        self._mode = mode
        self._velocity = None  # any new target replaces a velocity target

    def fly_velocity(self, velocity: NED, for_s: float) -> None:
        """Fly at ``velocity`` (north, east, down m/s) for ``for_s`` vehicle seconds, then brake
        and hold where it stops, unless a new target comes (ArduPilot's GUID_TIMEOUT)."""
        if self._phase is not FlightPhase.FLYING:
            raise VehicleError(f"{self.vehicle_id}: a velocity target needs the vehicle flying")
        self._refuse_unless_can_fly()
        self._fly(FlightMode.GUIDED)
        self._velocity = (velocity.n, velocity.e, velocity.d, self._t + for_s)

    def _begin_landing(self) -> None:
        self._velocity = None
        sn, se, _ = self._kin.stop_point(self.limits)
        self._target = (sn, se, 0.0)
        self._phase = FlightPhase.LANDING
        self._mode = FlightMode.LAND

    def _motors_off(self) -> None:
        self._velocity = None
        self._armed, self._arming_since = False, None
        self._target = None
        self._phase = FlightPhase.FALLING
        self._mode = FlightMode.STABILIZE

    def _refuse_if_rebooting(self) -> None:
        if self._reboot_until is not None:
            left = self._reboot_until - self._t
            raise VehicleError(f"{self.vehicle_id}: rebooting ({left:.1f} s left); try again then")

    def _refuse_unless_can_fly(self) -> None:
        self._refuse_if_rebooting()
        if self._phase is FlightPhase.FALLING:
            raise VehicleError(f"{self.vehicle_id}: motors are off, it is falling")
        if not self._armed:
            if self._arming_since is not None:
                left = self.arming_s - (self._t - self._arming_since)
                raise VehicleError(f"{self.vehicle_id}: still arming ({left:.1f} s left)")
            raise VehicleError(f"{self.vehicle_id}: not armed; arm it first")
        if self._failsafe and self._phase is FlightPhase.LANDING:
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
