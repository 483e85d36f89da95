"""The air traffic a new plan must keep clear of (issue 14): what every other drone will fly.

Gathered on the event loop from the planner's own records (cheap: lists of steps), predicted in
the planning worker (:mod:`.deconflict`). A drone flying a leg will fly the steps it has not
reported yet, from where its last heartbeat put it; one hovering with no mission stays where it
is; one on the ground with no mission is not traffic. A drone in the air that the ground no
longer hears (lost, or its autopilot's link lost) is an orphan (ground/planner/orphans.py): its
last place, its way to its goal and its drift are kept clear, as well as the rest of its leg
(it may be flying on), until it is heard again.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from dronefleet.ground.planner import orphans
from dronefleet.ground.planner.deconflict import Placed, Share, separate
from dronefleet.ground.planner.fleet_view import DroneView
from dronefleet.ground.planner.models import Leg, MissionRecord
from dronefleet.ground.planner.ops import PlannerOps
from dronefleet.messaging.commands import Command

#: Steps that give the vehicle a new goal: the rest of a leg starts again from the last one.
_GOALS = frozenset({Command.TAKEOFF, Command.NAVIGATE, Command.LAND, Command.RTL})


def remaining_steps(leg: Leg, work: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The steps of ``leg`` its drone has not reported, led by the goal it is flying to."""
    steps = leg.drone_steps(work)
    done = max((r.drone_step for r in leg.reports), default=-1)
    rest = steps[done + 1 :]
    if rest and rest[0].get("command") not in _GOALS:
        goal = next((s for s in reversed(steps[: done + 1]) if s.get("command") in _GOALS), None)
        if goal is not None and goal.get("command") != Command.TAKEOFF:
            rest = [goal, *rest]
    return rest


def traffic(
    missions: Iterable[MissionRecord],
    fleet: Iterable[DroneView],
    exclude: set[str],
    *,
    latest: Mapping[str, dict[str, Any]] | None = None,
) -> list[Share]:
    """Every drone not in ``exclude`` that is or will be in the air, as a share flown as is, and
    every orphan (a drone in the air not heard: :func:`orphan_of`, from its ``latest``
    telemetry when the planner has it)."""
    views = {d.drone_id: d for d in fleet}
    found: dict[str, Share] = {}
    orphans = [
        orphan_of(d, (latest or {}).get(d.drone_id))
        for d in views.values()
        if not d.online and d.airborne and d.drone_id not in exclude
    ]
    for record in missions:
        if record.terminal:
            continue
        for leg in record.legs:
            drone = views.get(leg.drone_id)
            if not leg.active or drone is None or leg.drone_id in exclude:
                continue
            found[leg.drone_id] = Share(
                leg.drone_id, [], remaining_steps(leg, record.work), [], drone.position,
                drone.home, drone.airborne, drone.flight,
            )  # fmt: skip
    for drone in views.values():
        if drone.drone_id in found or drone.drone_id in exclude:
            continue
        if drone.online and drone.airborne:
            found[drone.drone_id] = Share(
                drone.drone_id, [], [], [], drone.position, drone.home, True, drone.flight
            )
    return [*found.values(), *orphans]


def orphan_of(drone: DroneView, telemetry: dict[str, Any] | None = None) -> Share:
    """``drone`` (not heard, in the air) as traffic: kept clear of where it was."""
    orphan = orphans.of_drone(
        drone.drone_id,
        drone.position,
        telemetry=telemetry,
        speed_mps=drone.ground_speed_mps,
        age_s=drone.seen_ago_s,
    )
    return Share(
        drone.drone_id, [], [], [], orphan.last, drone.home, True, drone.flight, orphan=orphan
    )


def _separate(
    shares: list[Share], others: list[Share], ceiling_m: float | None, alter_work: bool = False
) -> list[Placed]:
    return separate(shares, others, ceiling_m=ceiling_m, alter_work=alter_work)


async def keep_apart(
    planner: PlannerOps,
    fleet: Iterable[DroneView],
    shares: list[Share],
    *,
    also: Iterable[Share] = (),
    alter_work: bool = False,
) -> list[Placed]:
    """``shares`` placed clear of every other drone in the air, of every orphan, and of ``also``
    (drones whose next steps are decided but not yet sent), in the planning worker; with
    ``alter_work``, their work may change near an orphan (the caller sends
    :attr:`~.deconflict.Placed.work`). Raises
    :class:`~dronefleet.ground.planner.separation.SeparationConflict` when they cannot be."""
    extra = list(also)
    mine = {s.drone_id for s in [*shares, *extra]}
    others = traffic(planner.missions.values(), fleet, exclude=mine, latest=planner.latest)
    others += extra
    return await planner.worker.run(_separate, shares, others, planner.max_altitude_m, alter_work)
