"""Per-unit figures of a route made of a few kinds of unit (issue 30: the 1 km² field at 10 m,
planned and split among 10 drones in 200 ms of CPU).

:func:`dronefleet.ground.planner.allocation.split_route` needs, for every unit of a route, the
seconds and mAh of its leg and of what follows it — the estimator's figures for the whole route,
flown from its first waypoint. Building the route's ten thousand step dictionaries and reading
them back (:class:`.units.Units`) took longer than flying it. Here the units come as kinds (units
of one kind have the same steps but for their ``navigate``'s lat/lon) and their targets as
arrays: a unit's steps are asked for only when the unit is flown rather than replayed. The
vehicle, the replays and their keys are the estimator's own (:mod:`.units`, :mod:`.state`), in
the same order, so the figures are :func:`.replay.estimate`'s to the bit.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from dronefleet.geo.ned import lla_to_ned, local_frame
from dronefleet.geo.types import LLA
from dronefleet.ground.planner.estimate.state import _State
from dronefleet.ground.planner.estimate.units import (
    _MM,
    HOLDS,
    Keys,
    Replay,
    Unit,
    fly_unit,
    state_key,
)
from dronefleet.ground.planner.estimate.vehicle import DEFAULT_MODEL, VehicleModel

Steps = list[dict[str, Any]]


@dataclass(frozen=True)
class UnitCosts:
    """Per unit: seconds and mAh of its leg (``navigate`` and ``wait_for_flight``) and of the
    rest (the holds and any steps after them)."""

    leg_s: np.ndarray
    hold_s: np.ndarray
    leg_mah: np.ndarray
    hold_mah: np.ndarray


@dataclass(frozen=True)
class _Layout:
    """A kind of unit: its replayed part (steps ``0..end``), signature number, and whether steps
    follow that part (flown one by one, as :func:`.replay.estimate` does)."""

    end: int
    signature: int
    rest: bool

    @classmethod
    def of(cls, steps: Steps, keys: Keys) -> _Layout | None:
        commands = [s.get("command") for s in steps]
        if commands[:2] != ["navigate", "wait_for_flight"] or "navigate" in commands[2:]:
            return None
        end = 2
        while end < len(commands) and commands[end] in HOLDS:
            end += 1
        wait = steps[1]
        signature = (
            steps[0].get("altitude_delta"),
            wait.get("horizontal_tolerance_m"),
            wait.get("vertical_tolerance_m"),
            *[(commands[k], steps[k].get("value")) for k in range(2, end)],
        )
        return cls(end, keys.number(signature), end < len(steps))


_Sums = tuple[float, float, float, float]


def _sums(seconds: Sequence[float], mah: Sequence[float]) -> _Sums:
    """Leg (first two steps) and hold (the others), added in order as ``np.add.reduceat``."""
    hold_s = hold_mah = 0.0
    for k in range(2, len(seconds)):
        hold_s += seconds[k]
        hold_mah += mah[k]
    return seconds[0] + seconds[1], hold_s, mah[0] + mah[1], hold_mah


def _keyed(state: _State) -> bool:
    """Whether a unit flown from ``state`` may be replayed (see ``units._key``)."""
    on_its_way = state.in_air and not state.landing and state.armed and not state.homing
    return on_its_way and state.target is not None


def unit_costs(
    kind_of: Sequence[Hashable],
    lat: np.ndarray,
    lon: np.ndarray,
    steps_of: Callable[[int], Steps],
    start: LLA,
    home: LLA,
    *,
    model: VehicleModel = DEFAULT_MODEL,
) -> UnitCosts | None:
    """What :func:`.replay.estimate` says of ``steps_of(0) + steps_of(1) + ...`` flown airborne
    from ``start``, unit by unit; ``lat``/``lon`` are each unit's ``navigate`` target and units
    of one ``kind_of`` differ in nothing else (ValueError when a unit flown is not like its
    kind). None when a kind does not begin with ``navigate`` and ``wait_for_flight`` or has
    another ``navigate``, or when the vehicle is still flying home at the end (the estimator
    adds that to the last step)."""
    keys = Keys()
    layouts: dict[Hashable, _Layout] = {}
    signatures = []  # per unit: its signature, or -1 when its kind is not replayed whole
    for i, kind in enumerate(kind_of):  # signatures numbered in route order, as Units does
        layout = layouts.get(kind)
        if layout is None:
            found = _Layout.of(steps_of(i), keys)
            if found is None:
                return None
            layout = layouts[kind] = found
        signatures.append(-1 if layout.rest else layout.signature)
    here = lla_to_ned(start, home)
    state = _State(model, n=here.n, e=here.e, h=max(0.0, -here.d))
    state.armed = state.in_air = True
    state.target, state.target_h = (here.n, here.e), state.h
    dlon = (np.asarray(lon, dtype=float) - home.lon + 180.0) % 360.0 - 180.0
    north, east = local_frame(home).horizontal_many(np.asarray(lat, dtype=float), dlon).tolist()
    cache: dict[tuple, Replay] = {}
    # A replay's figures by its key, flat: target and move (north, east), charge, state key,
    # the unit's sums (their row in ``table``), the replay.
    replays: dict[tuple, tuple[float, float, float, float, float, int, int, Replay]] = {}
    table: list[_Sums] = []  # every unit's sums, distinct ones once
    out: list[int] = []  # per unit: its row of ``table``
    known: int | None = None  # the state's key part when the last unit was replayed
    # While units are replayed the state lives in these (written back before anything else).
    n, e, target, charge = state.n, state.e, state.target, state.charge_as
    last: Replay | None = None  # the replay applied last, when not written back yet
    keyed = _keyed(state)
    mm, rnd = _MM, round
    for i, (sig, tn_i, te_i) in enumerate(zip(signatures, north, east, strict=True)):
        key: tuple | None = None
        if keyed and sig >= 0:  # units.fly_unit's key, inline
            key = (
                rnd((tn_i - n) * mm), rnd((te_i - e) * mm),
                rnd((target[0] - n) * mm), rnd((target[1] - e) * mm),
                known if known is not None else state_key(state, keys),
                sig,
            )  # fmt: skip
            hit = replays.get(key)
            if hit is not None:  # a replay, as fly_unit applies it
                tn, te, mn, me, drawn, known, figures, last = hit
                target = (n + tn, e + te)
                n, e = n + mn, e + me
                charge += drawn
                out.append(figures)
                continue
        if last is not None:
            state.n, state.e, state.target, state.charge_as = n, e, target, charge
            state.vn, state.ve, state.vz = last.velocity
            state.h, state.target_h = last.height, last.target_h
            last = None
        steps, layout = steps_of(i), layouts[kind_of[i]]
        if _Layout.of(steps, keys) != layout:
            raise ValueError(f"unit {i} is not of its kind's steps")
        unit = Unit(0, layout.end, layout.signature)
        replay = fly_unit(state, (north[i], east[i]), unit, steps, home, cache, keys, known)
        known = replay.state_key
        seconds, mah = list(replay.seconds), list(replay.mah)
        for step in steps[layout.end :]:
            before = state.charge_as
            seconds.append(state.run(step, home))
            mah.append((state.charge_as - before) / 3.6)
            known = None
        figures = len(table)
        table.append(_sums(seconds, mah))
        if key is not None and cache.get(key) is replay:  # kept for replays
            r = replay
            replays[key] = (*r.target, *r.moved, r.charge_as, r.state_key, figures, r)
        out.append(figures)
        n, e, target, charge = state.n, state.e, state.target, state.charge_as
        keyed = _keyed(state)
    if state.homing:
        return None
    rows = np.array(table, dtype=float)[np.array(out)]
    leg_s, hold_s, leg_mah, hold_mah = rows.T.copy()
    return UnitCosts(leg_s, hold_s, leg_mah, hold_mah)
