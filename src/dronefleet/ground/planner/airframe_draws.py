"""The fleet's measured draw per airframe, kept in the ground's state (issue 28, item 2).

A drone measures the current its vehicle draws in the air (drone/draw.py) and reports it in its
heartbeats; a vehicle that has not flown yet is estimated with the draw measured on the other
drones of its airframe (estimate.with_fleet_draw), or a conservative one when none has flown.
Taken from the live heartbeats only, that knowledge went with the drone that measured it: a
ground restarted, or the drone's own software restarted (its measurement starts again at
nothing), and the next first flight was planned on the conservative figure again, or on its
own airframe's 18 A model before. Here every measured draw is written to the ground's state
per (airframe, drone) as plans are made, and the draws the planner uses are those kept, each
drone's latest: they survive a restart of either side.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import orjson

from dronefleet.ground.planner.estimate import airframe
from dronefleet.ground.planner.fleet_view import DroneView
from dronefleet.ground.state import StateStore


def _key_text(key: tuple) -> str:
    return orjson.dumps([list(pair) for pair in key]).decode()


def _key_of(text: str) -> tuple | None:
    try:
        pairs = orjson.loads(text)
        return tuple((str(k), v) for k, v in pairs)
    except (orjson.JSONDecodeError, TypeError, ValueError):
        return None  # a row written by another version: not this planner's key


def measured(fleet: Iterable[DroneView]) -> list[tuple[str, str, float]]:
    """``(airframe, drone_id, amperes)`` of every drone reporting a measured draw."""
    rows = []
    for drone in fleet:
        flight: dict[str, Any] = drone.flight or {}
        key, draw = airframe(flight), flight.get("flight_current_a")
        if key is not None and isinstance(draw, int | float) and draw > 0:
            rows.append((_key_text(key), drone.drone_id, float(draw)))
    return rows


async def learn(state: StateStore, fleet: Iterable[DroneView]) -> dict[tuple, list[float]]:
    """Keep the draws ``fleet`` reports now; the draws per airframe the planner uses (each
    drone's latest, kept or reported now)."""
    known = {(a, d): w for a, d, w in await state.load_airframe_draws()}
    new = [row for row in measured(fleet) if known.get((row[0], row[1])) != row[2]]
    if new:
        await state.save_airframe_draws(new)
        known.update({(a, d): w for a, d, w in new})
    draws: dict[tuple, list[float]] = {}
    for (text, _drone), draw in sorted(known.items()):
        key = _key_of(text)
        if key is not None:
            draws.setdefault(key, []).append(draw)
    return draws
