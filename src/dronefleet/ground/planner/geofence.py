"""Geofence: every drone's share checked before a mission is accepted (issue 14).

The fence (messaging/fence.py: inclusion polygon, exclusion polygons, ceiling above home) is a
mission option. Each share is checked as it would fly: from where the drone is, through every
``navigate`` of its preparation, work and end, back home when its end is a return (RTL flies
straight home). Every point must be inside the inclusion polygon and at or under the ceiling,
every straight leg between two points inside the inclusion polygon and clear of every
exclusion. A share that is not is refused with the drone, the step and where (REST 422);
nothing changes. The fence then goes with each leg to its drone, which keeps to it in flight.
Rally points (where a drone sent home early may land) must lie inside the fence too
(:func:`check_rally`): a drone sent to one must not breach the fence on arrival.
"""

from __future__ import annotations

import itertools
from typing import Any

from dronefleet.errors import InvalidInput
from dronefleet.geo.types import LLA
from dronefleet.messaging.commands import Command
from dronefleet.messaging.fence import FenceShape, Geofence, RallyPoint

__all__ = ["FenceBreach", "Geofence", "check_rally", "check_share"]


class FenceBreach(InvalidInput, ValueError):
    """A share that would leave the fence: the message says which drone, step and where."""


def check_share(
    fence: Geofence,
    drone_id: str,
    start: LLA,
    home: LLA,
    steps: list[dict[str, Any]],
    returns_home: bool,
) -> None:
    """Raise :class:`FenceBreach` when ``drone_id`` flying ``steps`` from ``start`` would leave
    ``fence`` (``returns_home``: its end flies straight home afterwards)."""
    shape = FenceShape(fence, start)
    path: list[tuple[str, LLA]] = [("where it starts", start)]
    for i, step in enumerate(steps):
        if step.get("command") == Command.NAVIGATE:
            height = step.get("altitude_delta")
            alt = home.alt_m + height if isinstance(height, int | float) else path[-1][1].alt_m
            path.append((f"step {i} (navigate)", LLA(step["lat"], step["lon"], alt)))
        elif step.get("command") == Command.TAKEOFF and _above(step.get("value"), fence):
            raise FenceBreach(
                f"fence: {drone_id} step {i} takes off to {step['value']:g} m, above the "
                f"fence ceiling of {fence.ceiling_m:g} m"
            )
    if returns_home:
        path.append(("its way home", home))
    for what, here in path:
        why = shape.breach(here, home)
        if why is not None:
            raise FenceBreach(
                f"fence: {drone_id} {what} at {here.lat:.6f}, {here.lon:.6f} is {why}"
                if why.startswith(("outside", "inside"))
                else f"fence: {drone_id} {what} at {here.lat:.6f}, {here.lon:.6f} flies {why}"
            )
    for (came, a), (went, b) in itertools.pairwise(path):
        why = shape.leg_breach(a, b)
        if why is not None:
            raise FenceBreach(f"fence: {drone_id} flying from {came} to {went} {why}")


def check_rally(fence: Geofence | None, points: list[RallyPoint]) -> None:
    """Raise :class:`FenceBreach` naming the first rally point outside ``fence`` (outside its
    inclusion polygon, in an exclusion zone, or to be flown to above its ceiling)."""
    if fence is None or not points:
        return
    shape = FenceShape(fence, LLA(points[0].lat, points[0].lon))
    for k, point in enumerate(points):
        ground = LLA(point.lat, point.lon, 0.0)  # heights here are above home: home at 0 m
        why = shape.breach(LLA(point.lat, point.lon, point.alt_m), ground)
        if why is not None:
            where = f"{point.lat:.6f}, {point.lon:.6f}"
            raise FenceBreach(
                f"fence: rally point {k + 1} at {where} is {why}"
                if why.startswith(("outside", "inside"))
                else f"fence: rally point {k + 1} at {where} is flown to {why}"
            )


def _above(height: Any, fence: Geofence) -> bool:
    return fence.ceiling_m is not None and float(height or 0.0) > fence.ceiling_m
