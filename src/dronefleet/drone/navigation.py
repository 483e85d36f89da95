"""Navigation Processor (seed 3.3.2.2, 4.1.2.2): high-level moves into flight-controller targets.

Navigation requests — absolute (``navigate``) or relative (``changeN``, ``changeE``,
``altitude``) — become position targets for the Flight Controller Interface. The current goal is
remembered so relative moves in a mission compose (two ``changeN 10`` = 20 m north of where the
first began) and so ``wait_for_flight`` knows what to wait for (Algorithm 1).

A position target is never sent while the vehicle is on the ground or still low in its take-off
climb: ArduPilot Copter's GUIDED mode turns a position target into a waypoint
(``ModeGuided::set_destination`` in ArduCopter/mode_guided.cpp), whose controller keeps the
motors idle while the vehicle is landed, so a ``navigate`` sent right after ``takeoff`` cancelled
the climb and the autopilot disarmed after DISARM_DELAY (issue 17). ``navigate`` therefore waits
until the vehicle is :data:`SAFE_HEIGHT_M` up, then flies on at full speed (climbing on the way).

A return asked for with ``rally`` (a drone sent home early: abort, handover, a lost drone heard
again) lands at the nearest of the running mission's rally points instead of home when one is
nearer (messaging/fence.py :func:`nearest_rally`), chosen here from where the drone really is.
"""

from __future__ import annotations

import asyncio
import logging
from dataclasses import dataclass

from dronefleet.clock import wait_until
from dronefleet.drone.takeover import ModeLedger
from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.messaging.fence import Geofence, RallyPoint, nearest_rally
from dronefleet.vehicle.base import FcError, FcRefused, FlightController

log = logging.getLogger(__name__)

#: Height above home a take-off must reach before a position target may follow it (metres); a
#: lower take-off target lowers it to half that target.
SAFE_HEIGHT_M = 2.0
#: Height of the flight home for an RTL of a flight controller without its own (ArduPilot's
#: RTL_ALT default, 15 m): higher if already higher.
RTL_ALT_M = 15.0
#: Longest a navigate waits for the take-off to reach that height (vehicle seconds): arming is
#: done by then, and ArduPilot's climb starts within a second of NAV_TAKEOFF.
TAKEOFF_WAIT_S = 30.0


@dataclass(frozen=True)
class Tolerance:
    """The cylinder of Figure 4.15: a goal is reached inside it."""

    horizontal_m: float = 2.0
    vertical_m: float = 2.0


def reached(goal: NED, actual: NED, tolerance: Tolerance) -> bool:
    """Algorithm 1: has the drone reached its goal (both criteria strictly inside tolerance)?"""
    vertical_error = goal.d - actual.d
    horizontal_error = (goal - actual).horizontal_m
    return abs(vertical_error) < tolerance.vertical_m and horizontal_error < tolerance.horizontal_m


class NavigationProcessor:
    """Turns navigation requests into position targets and tracks the current goal."""

    def __init__(
        self,
        fc: FlightController,
        *,
        takeoff_altitude_m: float = 10.0,
        max_altitude_m: float = 120.0,
        tolerance: Tolerance | None = None,
    ) -> None:
        self.fc = fc
        self.takeoff_altitude_m = takeoff_altitude_m
        self.max_altitude_m = max_altitude_m
        self.tolerance = tolerance or Tolerance()
        self.goal: LLA | None = None
        self.landing = False  # after a land request, the goal is being on the ground
        self.takeoff_height_m: float | None = None  # the take-off climb in progress, if any
        self._homing: asyncio.Task[None] | None = None  # our RTL's landing, once home
        # The running mission's rally points and fence (set by the Mission Worker).
        self.rally_points: list[RallyPoint] = []
        self.fence: Geofence | None = None
        self.modes = ModeLedger(fc)  # the flight modes we chose (drone/takeover.py)
        #: Why the drone must land where it is (its battery: drone/battery_guard.py); while set
        #: and in the air, nothing but a landing is flown (issue 26: a queued return order
        #: once overrode it).
        self.must_land: str | None = None

    # -- requests ----------------------------------------------------------------------------
    async def takeoff(self, altitude_m: float | None = None) -> LLA:
        height = self.takeoff_altitude_m if altitude_m is None else altitude_m
        self._may_fly("take-off")
        self._check_height(height)
        self._stop_homing()
        async with self.modes.choosing():
            await self.fc.takeoff(height)
        self.landing = False
        self.takeoff_height_m = height
        here = self.fc.position()
        self.goal = LLA(here.lat, here.lon, self.fc.home().alt_m + height)
        return self.goal

    async def navigate(self, lat: float, lon: float, altitude_m: float | None = None) -> LLA:
        """Fly to ``lat``/``lon`` at ``altitude_m`` above home (default: keep the goal's height)."""
        home = self.fc.home()
        if altitude_m is None:
            alt = self._base().alt_m
        else:
            self._check_height(altitude_m)
            alt = home.alt_m + altitude_m
        return await self._go(LLA(lat, lon, alt))

    async def change(self, north_m: float = 0.0, east_m: float = 0.0, up_m: float = 0.0) -> LLA:
        """Move relative to the current goal (or position when there is none)."""
        home = self.fc.home()
        base = lla_to_ned(self._base(), home)
        target = ned_to_lla(NED(base.n + north_m, base.e + east_m, base.d - up_m), home)
        self._check_height(target.alt_m - home.alt_m)
        return await self._go(target)

    async def return_to_launch(self, *, rally: bool = False) -> LLA:
        """Fly home and land there: the autopilot's own RTL where it has one (ArduPilot: climb
        to RTL_ALT, fly home, land), else the same here (:data:`RTL_ALT_M`). With ``rally``, to
        the nearest rally point nearer than home instead, at its height, and land there.
        ``wait_for_flight`` then waits until the drone is down. Returns where it lands."""
        self._may_fly("return home")
        home = self.fc.home()
        self._stop_homing()
        point = self._rally_point(home) if rally else None
        if point is not None:
            there = LLA(point.lat, point.lon, home.alt_m + point.alt_m)
            log.info(
                "RTL to the rally point at %.6f, %.6f (nearer than home)", there.lat, there.lon
            )
            await self._go(there)
            self._homing = asyncio.create_task(self._land_on_arrival(there), name="rtl")
            self.landing = True
            return there
        native = getattr(self.fc, "return_to_launch", None)
        if native is not None:
            async with self.modes.choosing():
                await native()
            self.goal, self.landing, self.takeoff_height_m = None, True, None
            return home
        if not self.fc.state().in_air:
            await self.land()
            return home
        height = max(self._height_m(), RTL_ALT_M)
        await self._go(LLA(home.lat, home.lon, home.alt_m + height))
        self._homing = asyncio.create_task(self._land_on_arrival(home), name="rtl")
        self.landing = True  # what wait_for_flight waits for: on the ground, at home
        return home

    def _rally_point(self, home: LLA) -> RallyPoint | None:
        """The rally point to land at instead of home, if any (only in the air: a drone still
        on the ground is just made safe where it is, as an RTL does)."""
        if not self.rally_points or not self.fc.state().in_air:
            return None
        return nearest_rally(self.rally_points, self.fc.position(), home, self.fence)

    async def _land_on_arrival(self, where: LLA) -> None:
        arrived = await wait_until(
            self.fc.clock,
            lambda: self.distance_to_goal_m() < self.tolerance.horizontal_m,
            poll_s=0.1,
        )
        if arrived and self._homing is asyncio.current_task():
            async with self.modes.choosing():
                await self.fc.land()
            self.goal = None
            log.info("RTL: at %.6f, %.6f, landing", where.lat, where.lon)

    def _stop_homing(self) -> None:
        task, self._homing = self._homing, None
        if task is not None and not task.done() and task is not asyncio.current_task():
            task.cancel()

    async def land(self) -> None:
        self._stop_homing()
        async with self.modes.choosing():
            await self.fc.land()
        self.goal = None
        self.takeoff_height_m = None
        self.landing = True

    async def hold(self) -> LLA:
        self._may_fly("hold")
        self._stop_homing()
        here = self.fc.position()
        async with self.modes.choosing():
            await self.fc.hold()
        self.goal = here
        return here

    async def resume(self) -> None:
        """Take the vehicle back after a takeover (drone/takeover.py): on to the goal it was
        flying to, or down where it is if it was landing."""
        homing = self._homing is not None and not self._homing.done()
        if self.landing and not homing:
            await self.land()
        elif self.goal is not None:
            await self._go(self.goal)

    # -- state -------------------------------------------------------------------------------
    def goal_reached(self, tolerance: Tolerance | None = None) -> bool:
        """Algorithm 1 against the current goal; after ``land`` the goal is being on the ground."""
        if self.landing:
            return not self.fc.state().in_air
        if self.goal is None:
            return True
        home = self.fc.home()
        return reached(
            lla_to_ned(self.goal, home),
            lla_to_ned(self.fc.position(), home),
            tolerance or self.tolerance,
        )

    def distance_to_goal_m(self) -> float:
        if self.goal is None:
            return 0.0
        home = self.fc.home()
        return (lla_to_ned(self.goal, home) - lla_to_ned(self.fc.position(), home)).norm_m

    # -- internals ---------------------------------------------------------------------------
    def _base(self) -> LLA:
        state = self.fc.state()
        if self.goal is not None and (state.in_air or state.armed):
            return self.goal
        return self.fc.position()

    def _height_m(self) -> float:
        return self.fc.position().alt_m - self.fc.home().alt_m

    async def _airborne(self, target: LLA) -> None:
        """Take off first if still on the ground, and wait until safely up (see module doc)."""
        state = self.fc.state()
        if self.takeoff_height_m is None:
            if state.in_air and self._height_m() > 0.5:
                return  # flying already (taken off earlier, or by someone else)
            await self.takeoff(max(target.alt_m - self.fc.home().alt_m, SAFE_HEIGHT_M))
        assert self.takeoff_height_m is not None
        safe_m = min(SAFE_HEIGHT_M, 0.5 * self.takeoff_height_m)
        up = await wait_until(
            self.fc.clock,
            lambda: self._height_m() >= safe_m,
            poll_s=0.05,
            timeout_s=TAKEOFF_WAIT_S,
        )
        if not up:
            raise FcError(
                f"take-off did not reach {safe_m:g} m within {TAKEOFF_WAIT_S:g} s "
                f"(at {self._height_m():.1f} m): is the vehicle armed and in a guided mode?"
            )
        self.takeoff_height_m = None

    def _may_fly(self, what: str) -> None:
        """Refuses ``what`` while the drone must land (:attr:`must_land`) and is in the air."""
        if self.must_land is not None and self.fc.state().in_air:
            raise FcRefused(f"{what} refused: {self.must_land}")

    def _check_height(self, height_m: float) -> None:
        if height_m < 0:
            raise FcRefused(
                f"target {height_m:.1f} m is below home; targets must be at or above it"
            )
        if height_m > self.max_altitude_m:
            raise FcRefused(
                f"target {height_m:.1f} m above home exceeds the {self.max_altitude_m:g} m limit"
            )

    async def _go(self, target: LLA) -> LLA:
        self._may_fly("navigation")
        state = self.fc.state()
        if not state.armed:
            raise FcError("vehicle is not armed: arm (and take off) before navigating")
        await self._airborne(target)
        if self._homing is not None and target != self.goal:
            self._stop_homing()  # a new destination ends an RTL of ours
        async with self.modes.choosing():
            await self.fc.goto(target)
        self.goal = target
        self.landing = self._homing is not None and not self._homing.done()
        return target
