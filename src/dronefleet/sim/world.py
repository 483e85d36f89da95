"""The sim world: one clock and one physics loop for every simulated vehicle in the process.

Each tick advances sim time by ``step_s``, steps every vehicle, then wakes the sleepers whose
deadline passed. The loop paces itself against wall time at ``speedup`` in batches: it works out
how many ticks are due since it last looked at the wall clock and runs them back to back, pausing
only when a sleeper wakes (so the woken coroutine sees the sim time it asked for) and to let the
event loop breathe. When it cannot keep up it runs flat out.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import time
from typing import TYPE_CHECKING, Any

from dronefleet.geo.types import LLA
from dronefleet.sim.clock import SimClock
from dronefleet.sim.gasfield import GasField
from dronefleet.sim.vehicle import SimVehicle
from dronefleet.sim.wind import CALM, Wind
from dronefleet.virtual_loop import VirtualTimeLoop

if TYPE_CHECKING:
    from dronefleet.sim.flight_controller import SimFlightController

log = logging.getLogger(__name__)

#: Shortest wall sleep when ahead of schedule (a finer sleep only burns CPU on timer overhead).
_MIN_WALL_SLEEP_S = 0.002
#: Longest stretch of back-to-back ticks before yielding to other tasks (wall seconds).
_MAX_BATCH_WALL_S = 0.02
#: Falling further behind than this (wall seconds of sim time) forgives the debt: no long bursts.
_MAX_LAG_WALL_S = 0.25
#: Float slack when counting due ticks (0.05 * 6 != 0.3 exactly).
_DUE_EPS = 1e-6


class SimWorld:
    """Many vehicles, one clock, one loop. ``async with SimWorld(speedup=20) as world: ...``"""

    def __init__(
        self,
        speedup: float = 1.0,
        step_s: float = 0.05,
        wind: Wind | None = None,
        gas_field: GasField | None = None,
    ) -> None:
        if not step_s > 0:
            raise ValueError(f"step_s must be positive, got {step_s}")
        self.clock = SimClock(speedup)
        self.step_s = step_s
        self.wind = wind
        self.gas_field = gas_field if gas_field is not None else GasField()
        self.vehicles: dict[str, SimVehicle] = {}
        self._task: asyncio.Task[None] | None = None
        self._rebase = True

    # -- vehicles -----------------------------------------------------------------------------
    def add_vehicle(self, vehicle_id: str, home: LLA, **params: Any) -> SimVehicle:
        """Create a vehicle at ``home`` (on the ground, disarmed); ``params`` go to
        :class:`SimVehicle` (e.g. ``initial_charge_pct=30``, ``gps_noise_m=1.5``)."""
        if vehicle_id in self.vehicles:
            raise ValueError(f"vehicle {vehicle_id!r} already exists in this world")
        params.setdefault("wind", self.wind)
        params.setdefault("start_time_s", self.clock.now())
        vehicle = SimVehicle(vehicle_id, home, **params)
        self.vehicles[vehicle_id] = vehicle
        return vehicle

    def set_wind(self, wind: Wind | None) -> None:
        """Change the wind for every vehicle (and the default for new ones)."""
        self.wind = wind
        for vehicle in self.vehicles.values():
            vehicle.wind = wind or CALM

    def remove_vehicle(self, vehicle_id: str) -> None:
        self.vehicles.pop(vehicle_id, None)

    def flight_controller(self, vehicle_id: str) -> SimFlightController:
        """A :class:`~.flight_controller.SimFlightController` for one of the vehicles."""
        from dronefleet.sim.flight_controller import SimFlightController

        return SimFlightController(self.vehicles[vehicle_id], self.clock)

    # -- time ---------------------------------------------------------------------------------
    @property
    def speedup(self) -> float:
        return self.clock.speedup

    @speedup.setter
    def speedup(self, value: float) -> None:
        self.clock.speedup = value
        self._rebase = True

    @property
    def running(self) -> bool:
        return self._task is not None and not self._task.done()

    def tick(self) -> int:
        """One physics step for every vehicle; returns how many sleepers woke."""
        dt = self.step_s
        for vehicle in self.vehicles.values():
            vehicle.step(dt)
        return self.clock.advance(dt)

    def advance(self, duration_s: float) -> None:
        """Run ``duration_s`` of sim time now, without pacing (for tests and scripts)."""
        for _ in range(round(duration_s / self.step_s)):
            self.tick()

    async def start(self) -> None:
        if self.running:
            return
        if isinstance(asyncio.get_running_loop(), VirtualTimeLoop):
            self.clock.speedup = 1.0  # the loop's time is vehicle time; the loop does the pacing
        self._rebase = True
        self._task = asyncio.create_task(self._run(), name="sim-world")

    async def stop(self) -> None:
        task, self._task = self._task, None
        if task is None:
            return
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task

    async def __aenter__(self) -> SimWorld:
        await self.start()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.stop()

    async def _run(self) -> None:
        # Paced against the event loop's clock: the wall clock on an ordinary loop, virtual time
        # on a :class:`~dronefleet.virtual_loop.VirtualTimeLoop` (where the world runs at
        # speedup 1 and each tick is a timer of its own, so ticks land on exact virtual times).
        loop = asyncio.get_running_loop()
        clock, step = self.clock, self.step_s
        loop_ref = sim_ref = 0.0
        try:
            while True:
                if self._rebase:
                    loop_ref, sim_ref, self._rebase = loop.time(), clock.now(), False
                speedup = clock.speedup
                if math.isinf(speedup):
                    due = math.inf
                else:
                    behind_s = (loop.time() - loop_ref) * speedup - (clock.now() - sim_ref)
                    due = behind_s / step + _DUE_EPS
                    if behind_s > _MAX_LAG_WALL_S * speedup:
                        self._rebase = True  # hopelessly behind: run flat out from here
                if due < 1.0:
                    wait_s = (1.0 - due + _DUE_EPS) * step / speedup
                    await asyncio.sleep(max(wait_s, self._min_sleep_s(loop)))
                    continue
                self._run_batch(due)
                await asyncio.sleep(0)
        except Exception:
            log.exception("sim world loop crashed at t=%.2f s", clock.now())
            raise

    @staticmethod
    def _min_sleep_s(loop: asyncio.AbstractEventLoop) -> float:
        # A finer wall sleep only burns CPU on timer overhead; a virtual one costs nothing.
        return 0.0 if hasattr(loop, "epoch_time") else _MIN_WALL_SLEEP_S

    def _run_batch(self, due: float) -> None:
        wall_start = time.monotonic()  # a wall budget: yield to other tasks now and then
        ran = 0
        while ran + 1 <= due:
            ran += 1
            if self.tick():
                return  # let the woken coroutines run at their time
            if time.monotonic() - wall_start > _MAX_BATCH_WALL_S:
                return
