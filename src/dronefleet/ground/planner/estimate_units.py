"""Repeated units estimated once (issue 11: the 1 km² field at 10 m over 10 drones).

A coverage route in stop mode is thousands of identical units: ``navigate`` 10 m along a swath,
``wait_for_flight``, then what is done there (``takepic``, ``sleep``, ``read_sensors``), from
the same incoming speed. Flying each through the estimator was most of the split's time. A
unit's outcome does not depend on where it is flown, only on the state relative to the vehicle
(target offset, velocity, height) and on its steps; so a unit from an airborne state is flown
once per distinct key (offsets and speeds to the millimetre, the hold steps as given) and
replayed by translation afterwards. A state the key does not describe (landing, not armed,
notes written) is always flown. The navigate targets come in already converted to the local
frame (:func:`targets`, vectorised), so a replayed unit costs a key and a dictionary lookup.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from dronefleet.geo.ned import local_frame
from dronefleet.geo.types import LLA

_MM = 1000.0  # keys count millimetres and millimetres per second (round(x * _MM): an int)
#: Steps that hold the vehicle where it is: part of a unit after its wait_for_flight.
HOLDS = frozenset({"takepic", "sleep", "read_sensors"})


def targets(steps: list[dict[str, Any]], home: LLA) -> dict[int, tuple[float, float]]:
    """North and east of home of every navigate step, by step index, in one vectorised pass."""
    index = [i for i, s in enumerate(steps) if s.get("command") == "navigate"]
    if not index:
        return {}
    lat = np.array([steps[i]["lat"] for i in index], dtype=float)
    lon = np.array([steps[i]["lon"] for i in index], dtype=float)
    dlon = (lon - home.lon + 180.0) % 360.0 - 180.0
    north, east = local_frame(home).horizontal_many(lat, dlon)
    return dict(zip(index, zip(north.tolist(), east.tolist(), strict=True), strict=True))


def _key(
    state: Any,
    ned: tuple[float, float],
    nav: dict[str, Any],
    wait: dict[str, Any],
    holds: tuple[dict[str, Any], ...],
) -> tuple | None:
    if not state.in_air or state.landing or not state.armed or state.target is None:
        return None
    tn, te = state.target
    n, e, h, th = state.n, state.e, state.target_h, nav.get("altitude_delta")
    return (
        round((ned[0] - n) * _MM), round((ned[1] - e) * _MM), th and round(th * _MM),
        round((tn - n) * _MM), round((te - e) * _MM),
        round(state.vn * _MM), round(state.ve * _MM), round(state.vz * _MM),
        round(state.h * _MM), h and round(h * _MM),
        wait.get("horizontal_tolerance_m"), wait.get("vertical_tolerance_m"),
        tuple((s.get("command"), s.get("value")) for s in holds),
    )  # fmt: skip


def fly_unit(
    state: Any,
    ned: tuple[float, float],
    unit: tuple[dict[str, Any], ...],
    home: LLA,
    cache: dict[tuple, tuple],
) -> list[tuple[float, float]]:
    """Run ``unit`` (navigate, wait_for_flight, holds...) on ``state``: (duration,
    ampere-seconds) of each step. ``ned`` is the navigate target in the home frame."""
    nav, wait, holds = unit[0], unit[1], unit[2:]
    key = _key(state, ned, nav, wait, holds)
    hit = cache.get(key) if key is not None else None
    if hit is not None:
        costs, dn, de, vn, ve, h, vz, tn, te, th = hit
        n0, e0 = state.n, state.e
        state.n, state.e, state.vn, state.ve, state.h, state.vz = n0 + dn, e0 + de, vn, ve, h, vz
        state.target = (n0 + tn, e0 + te)
        state.target_h = th
        state.charge_as += sum(c for _, c in costs)
        return costs
    n0, e0, notes = state.n, state.e, len(state.notes)
    costs = []
    for step in unit:
        before = state.charge_as
        duration = state.run(step, home)
        costs.append((duration, state.charge_as - before))
    if key is not None and len(state.notes) == notes and state.target is not None:
        tn, te = state.target
        cache[key] = (
            costs, state.n - n0, state.e - e0, state.vn, state.ve, state.h, state.vz,
            tn - n0, te - e0, state.target_h,
        )  # fmt: skip
    return costs


def unit_at(steps: list[dict[str, Any]], i: int) -> tuple[dict[str, Any], ...] | None:
    """The unit starting at step ``i`` (navigate, wait_for_flight, holds), or None."""
    if steps[i].get("command") != "navigate" or i + 1 >= len(steps):
        return None
    if steps[i + 1].get("command") != "wait_for_flight":
        return None
    end = i + 2
    while end < len(steps) and steps[end].get("command") in HOLDS:
        end += 1
    return tuple(steps[i:end])
