"""Repeated units estimated once (issue 11: the 1 km² field at 10 m over 10 drones).

A coverage route in stop mode is thousands of identical units: ``navigate`` 10 m along a swath,
``wait_for_flight``, then what is done there (``takepic``, ``sleep``, ``read_sensors``), from
the same incoming speed. Flying each through the estimator was most of the split's time. A
unit's outcome does not depend on where it is flown, only on the state relative to the vehicle
(target offset, velocity, height) and on its steps; so a unit from an airborne state is flown
once per distinct key (offsets and speeds to the millimetre, the hold steps as given) and
replayed by translation afterwards. A state the key does not describe (landing, not armed,
notes written) is always flown. The navigate targets come in already converted to the local
frame (:func:`targets`, vectorised), and the units' bounds and step signatures are found in one
pass over the commands (:func:`units`), so a replayed unit costs four roundings, a dictionary
lookup and two list extensions.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from dronefleet.geo.ned import local_frame
from dronefleet.geo.types import LLA

_MM = 1000.0  # keys count millimetres and millimetres per second (round(x * _MM): an int)
#: Steps that hold the vehicle where it is: part of a unit after its wait_for_flight.
HOLDS = frozenset({"takepic", "sleep", "read_sensors"})


class Unit(NamedTuple):
    """Steps ``start``..``end`` (navigate, wait_for_flight, holds) and what fixes their outcome
    besides the vehicle's state (the navigate's height, the wait's and holds' values), as the
    number of that signature among the route's (a key of small integers hashes fast)."""

    start: int
    end: int
    signature: int


@dataclass(frozen=True)
class Replay:
    """A unit flown once: per-step seconds and mAh, and the state after it relative to before
    (position moved, velocities, height, target offset) with its key part already rounded."""

    seconds: list[float]
    mah: list[float]
    charge_as: float
    moved: tuple[float, float]
    velocity: tuple[float, float, float]
    height: float
    target: tuple[float, float]
    target_h: float | None
    state_key: int


class Keys:
    """Numbers for the signatures and vehicle states met in one estimate."""

    def __init__(self) -> None:
        self._known: dict[tuple, int] = {}

    def number(self, value: tuple) -> int:
        return self._known.setdefault(value, len(self._known))


class Units:
    """The units of a list of steps, in order: their bounds and signatures, and their navigate
    targets north and east of home (converted in one vectorised pass)."""

    def __init__(self, steps: list[dict[str, Any]], home: LLA, keys: Keys) -> None:
        commands = [s.get("command") for s in steps]
        self.items: list[Unit] = []
        for i, command in enumerate(commands):
            if command != "navigate" or i + 1 >= len(commands):
                continue
            if commands[i + 1] != "wait_for_flight":
                continue
            end = i + 2
            while end < len(commands) and commands[end] in HOLDS:
                end += 1
            wait = steps[i + 1]
            holds = [(commands[k], steps[k].get("value")) for k in range(i + 2, end)]
            signature = (
                steps[i].get("altitude_delta"),
                wait.get("horizontal_tolerance_m"),
                wait.get("vertical_tolerance_m"),
                *holds,
            )
            self.items.append(Unit(i, end, keys.number(signature)))
        self.at = {u.start: k for k, u in enumerate(self.items)}
        lat = np.array([steps[u.start]["lat"] for u in self.items], dtype=float)
        lon = np.array([steps[u.start]["lon"] for u in self.items], dtype=float)
        dlon = (lon - home.lon + 180.0) % 360.0 - 180.0
        north, east = local_frame(home).horizontal_many(lat, dlon)
        self.targets = list(zip(north.tolist(), east.tolist(), strict=True))


def state_key(state: Any, keys: Keys) -> int:
    """The part of a key that describes the vehicle alone (velocities and heights, rounded)."""
    h = state.target_h
    return keys.number((
        round(state.vn * _MM), round(state.ve * _MM), round(state.vz * _MM),
        round(state.h * _MM), h and round(h * _MM),
    ))  # fmt: skip


def _key(
    state: Any, ned: tuple[float, float], unit: Unit, known: int | None, keys: Keys
) -> tuple | None:
    if not state.in_air or state.landing or not state.armed or state.target is None or state.homing:
        return None
    tn, te = state.target
    n, e = state.n, state.e
    return (
        round((ned[0] - n) * _MM), round((ned[1] - e) * _MM),
        round((tn - n) * _MM), round((te - e) * _MM),
        known if known is not None else state_key(state, keys),
        unit.signature,
    )  # fmt: skip


def fly_unit(
    state: Any,
    ned: tuple[float, float],
    unit: Unit,
    steps: list[dict[str, Any]],
    home: LLA,
    cache: dict[tuple, Replay],
    keys: Keys,
    known: int | None = None,
) -> Replay:
    """Run ``unit`` on ``state`` (replayed when an equal one was flown); ``ned`` is its
    navigate target in the home frame, ``known`` the state's :func:`state_key` when the last
    unit was a replay (its velocities and heights are then the replay's, exactly)."""
    key = _key(state, ned, unit, known, keys)
    hit = cache.get(key) if key is not None else None
    if hit is not None:
        n0, e0 = state.n, state.e
        state.n, state.e = n0 + hit.moved[0], e0 + hit.moved[1]
        state.vn, state.ve, state.vz = hit.velocity
        state.h, state.target_h = hit.height, hit.target_h
        state.target = (n0 + hit.target[0], e0 + hit.target[1])
        state.charge_as += hit.charge_as
        return hit
    n0, e0, notes, charge0 = state.n, state.e, len(state.notes), state.charge_as
    seconds, mah = [], []
    for step in steps[unit.start : unit.end]:
        before = state.charge_as
        seconds.append(state.run(step, home))
        mah.append((state.charge_as - before) / 3.6)
    tn, te = state.target if state.target is not None else (state.n, state.e)
    replay = Replay(
        seconds, mah, state.charge_as - charge0, (state.n - n0, state.e - e0),
        (state.vn, state.ve, state.vz), state.h, (tn - n0, te - e0), state.target_h,
        state_key(state, keys),
    )  # fmt: skip
    if key is not None and len(state.notes) == notes and state.target is not None:
        cache[key] = replay
    return replay
