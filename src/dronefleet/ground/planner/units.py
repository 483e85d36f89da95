"""Waypoint units: the grain at which work is resumed, handed over and split.

A unit begins with a movement (navigate, changeN/E, altitude, takeoff, land) and takes the steps
that follow it up to the next movement: its ``wait_for_flight``, its action (takepic,
read_sensors, sleep). A unit is *done* when all its steps are. A replacement resumes at the first
unit not done, so no waypoint is skipped and none is flown twice; alarm steps are never re-sent.
"""

from __future__ import annotations

from typing import Any

from dronefleet.messaging.commands import Command

MOVES = frozenset(
    {
        Command.NAVIGATE,
        Command.CHANGE_N,
        Command.CHANGE_E,
        Command.ALTITUDE,
        Command.TAKEOFF,
        Command.LAND,
    }
)
#: Steps that only make sense once, where they were: never part of a resumed or split mission.
ONCE = frozenset({Command.VIRTUALALARM, Command.ARM, Command.DISARM})


def units(work: list[dict[str, Any]], indices: list[int] | None = None) -> list[list[int]]:
    """Group global step indices into units (movement + the steps until the next movement)."""
    indices = list(range(len(work))) if indices is None else indices
    groups: list[list[int]] = []
    for i in indices:
        if not groups or work[i].get("command") in MOVES:
            groups.append([i])
        else:
            groups[-1].append(i)
    return groups


def remaining(work: list[dict[str, Any]], indices: list[int], done: set[int]) -> list[int]:
    """Indices still to fly: every step of every unit that is not wholly done, minus ONCE steps."""
    left: list[int] = []
    for group in units(work, indices):
        if all(i in done for i in group):
            continue
        left.extend(i for i in group if work[i].get("command") not in ONCE)
    return left


def waypoints(
    work: list[dict[str, Any]], indices: list[int]
) -> list[tuple[float, float, float | None]]:
    """(lat, lon, height) of each ``navigate`` among ``indices``, in order."""
    return [
        (work[i]["lat"], work[i]["lon"], work[i].get("altitude_delta"))
        for i in indices
        if work[i].get("command") == Command.NAVIGATE
    ]


def first_target(work: list[dict[str, Any]], indices: list[int]) -> dict[str, Any] | None:
    """The first ``navigate`` step among ``indices`` (where a drone must go first)."""
    return next((work[i] for i in indices if work[i].get("command") == Command.NAVIGATE), None)
