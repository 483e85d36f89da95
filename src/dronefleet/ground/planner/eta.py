"""Each drone's time left in a running mission (issue 29: the progress view's ETA).

The time is the project's estimator (ground/planner/estimate/) replaying the steps a drone has
left, from where it is now, with its vehicle's figures and the mission's wind: vehicle seconds,
as every estimate. Estimates are CPU work, so they run in the planning worker
(ground/planner/worker.py), never on the event loop, and once per step: each drone's answer is
kept until it reports its next step (or pauses, or resumes). A request waits for new figures
only briefly (:data:`WAIT_S`); past that it is answered with the figures it had, marked
``eta_pending``, and the worker's answer is there for the next one.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import weakref
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

from dronefleet.geo.types import LLA
from dronefleet.ground.planner.estimate import estimate, vehicle_model
from dronefleet.ground.planner.fleet_view import DroneView
from dronefleet.ground.planner.models import Leg, MissionRecord
from dronefleet.ground.planner.worker import PlanningWorker
from dronefleet.messaging.commands import Command

log = logging.getLogger(__name__)

#: Wall seconds a progress request waits for new estimates before answering with the last ones.
WAIT_S = 2.0
#: Legs whose estimates are kept at most (the oldest go first).
MAX_KEPT = 4096


@dataclass(frozen=True)
class EtaJob:
    """What the worker needs to estimate one drone's steps left (all picklable)."""

    steps: list[dict[str, Any]]
    start: LLA
    home: LLA
    airborne: bool
    battery_pct: float
    flight: dict[str, Any] | None
    wind: dict[str, Any] | None
    wind_mps: float | None
    wind_from_deg: float


def remaining_s(jobs: list[EtaJob]) -> list[float | None]:
    """Vehicle seconds each job's steps take (runs in the planning worker); None where the
    estimator could not replay them."""
    answers: list[float | None] = []
    for job in jobs:
        try:
            model, _ = vehicle_model(
                job.flight, reported_wind=job.wind, wind_mps=job.wind_mps,
                wind_from_deg=job.wind_from_deg,
            )  # fmt: skip
            est = estimate(
                job.steps, job.start, job.home, airborne=job.airborne,
                battery_pct=job.battery_pct, model=model,
            )  # fmt: skip
            answers.append(round(est.duration_s, 1))
        except Exception:  # a step the estimator cannot replay: no figure, never a failure
            log.debug("no estimate for %d steps", len(job.steps), exc_info=True)
            answers.append(None)
    return answers


def current_step(leg: Leg) -> int:
    """The drone step ``leg``'s drone flies now: the one after the last it reported done."""
    return max((r.drone_step for r in leg.reports), default=-1) + 1


def steps_left(record: MissionRecord, leg: Leg) -> list[dict[str, Any]]:
    """The steps ``leg``'s drone has left. A ``wait_for_flight`` in progress keeps the
    ``navigate`` before it: that is where the drone is flying to."""
    steps = leg.drone_steps(record.work)
    first = current_step(leg)
    waiting = 0 < first < len(steps) and steps[first].get("command") == Command.WAIT_FOR_FLIGHT
    if waiting and steps[first - 1].get("command") == Command.NAVIGATE:
        first -= 1
    return steps[first:]


@dataclass(frozen=True)
class Eta:
    eta_s: float | None  # vehicle seconds left; None when unknown
    pending: bool  # newer figures are being estimated


class MissionEtas:
    """The estimates of one planner's running legs, keyed by how far each leg has got."""

    def __init__(self, worker: PlanningWorker) -> None:
        self.worker = worker
        self._known: dict[str, tuple[tuple[Any, ...], float | None]] = {}
        self._running: dict[str, asyncio.Task[None]] = {}  # mission id -> its estimates

    @staticmethod
    def key(leg: Leg) -> tuple[Any, ...]:
        return (current_step(leg), leg.paused is not None, leg.state.value)

    async def of(
        self,
        record: MissionRecord,
        fleet: Callable[[], Awaitable[list[dict[str, Any]]]],
        *,
        wait_s: float = WAIT_S,
    ) -> dict[str, Eta]:
        """Each active leg's time left (by leg id), estimated anew for the legs that moved on;
        ``fleet()`` gives the drones' records (asked only then)."""
        legs = record.active_legs()
        stale = [leg for leg in legs if self._known.get(leg.leg_id, (None,))[0] != self.key(leg)]
        task = self._running.get(record.mission_id)
        if stale and task is None:
            task = asyncio.create_task(self._estimate(record, stale, fleet))
            self._running[record.mission_id] = task
            task.add_done_callback(lambda _t: self._running.pop(record.mission_id, None))
        if task is not None:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(wait_s):
                    await asyncio.shield(task)
        answer = {}
        for leg in legs:
            key, seconds = self._known.get(leg.leg_id, (None, None))
            answer[leg.leg_id] = Eta(seconds, key != self.key(leg))
        return answer

    async def _estimate(
        self,
        record: MissionRecord,
        legs: list[Leg],
        fleet: Callable[[], Awaitable[list[dict[str, Any]]]],
    ) -> None:
        try:
            views = {v.drone_id: v for v in map(DroneView.from_public, await fleet()) if v}
        except Exception as exc:  # the Identifier did not answer: figures come next time
            log.info("no estimates for mission %s: %s", record.mission_id, exc)
            return
        keys, jobs = [], []
        for leg in legs:
            view = views.get(leg.drone_id)
            if view is None:
                self._known[leg.leg_id] = (self.key(leg), None)  # not heard: no figure
                continue
            keys.append((leg.leg_id, self.key(leg)))
            jobs.append(self._job(record, leg, view))
        if not jobs:
            return
        try:
            seconds = await self.worker.run(remaining_s, jobs)
        except Exception as exc:  # too complex, or the worker broke: no figure this time
            log.info("no estimates for mission %s: %s", record.mission_id, exc)
            seconds = [None] * len(jobs)
        for (leg_id, key), value in zip(keys, seconds, strict=True):
            self._known.pop(leg_id, None)
            self._known[leg_id] = (key, value)
        while len(self._known) > MAX_KEPT:
            self._known.pop(next(iter(self._known)))

    @staticmethod
    def _job(record: MissionRecord, leg: Leg, view: DroneView) -> EtaJob:
        options = record.options
        return EtaJob(
            steps=steps_left(record, leg), start=view.position, home=view.home,
            airborne=view.airborne, battery_pct=view.battery_pct, flight=view.flight,
            wind=view.wind, wind_mps=options.wind_mps, wind_from_deg=options.wind_from_deg,
        )  # fmt: skip


_OF: weakref.WeakKeyDictionary[Any, MissionEtas] = weakref.WeakKeyDictionary()


def etas_of(planner: Any) -> MissionEtas:
    """The estimates kept for ``planner`` (one set per Mission Planner)."""
    found = _OF.get(planner)
    if found is None:
        found = _OF[planner] = MissionEtas(planner.worker)
    return found
