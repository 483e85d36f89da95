"""Sharing a route among drones so that the work ends as early as possible (seed 4.2.4, 5.4).

The seed's Mission Planner gave each drone an equal share of the waypoints, in route order
(:func:`seed_equal_split`, kept for the baseline). Here each drone's finish time is costed —
preparation (arming, climb) when on the ground, transit to its first waypoint, then its work
(legs and holds, from :mod:`.estimate`) — and the split minimises the latest finish (makespan).

Shares are contiguous chunks of the boustrophedon route, so drones work in separate regions.
The makespan is found by bisection: for a candidate time ``T`` and an order of drones along the
route, the chunk starts reachable by the first ``m`` drones within ``T`` are every allowed start
up to some index (see :mod:`.allocation_search`), so one bisect per drone answers it; every order
is tried, up to ``max_orders`` (5 drones: 120 orders; 10 drones: the first 720, sharing prefixes,
skipping those that cannot end in time).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, fields
from operator import attrgetter
from typing import Any

import numpy as np

from dronefleet.geo.ned import lla_to_ned, local_frame
from dronefleet.geo.types import LLA
from dronefleet.ground.planner.allocation_search import _Route, _Search
from dronefleet.ground.planner.coverage.path import RoutePoint
from dronefleet.ground.planner.coverage.plan import CoveragePlan
from dronefleet.ground.planner.estimate import DEFAULT_MODEL, VehicleModel, estimate
from dronefleet.ground.planner.estimate.repeated import UnitCosts, unit_costs

_PRECISION_S = 0.02


@dataclass(frozen=True)
class DroneSlot:
    """A drone that can take a share: where it is, whether it flies, its battery and home."""

    drone_id: str
    position: LLA
    airborne: bool
    battery_pct: float = 100.0
    home: LLA | None = None  # default: below ``position`` (airborne) or at it (on the ground)


@dataclass(frozen=True)
class Assignment:
    """A drone's share: contiguous waypoint indices and when it should be done (s from now)."""

    drone_id: str
    waypoint_indices: list[int]
    estimated_finish_s: float
    altitude_offset_m: float = 0.0
    start_s: float = 0.0  # preparation and transit before its first waypoint


def altitude_offsets(count: int, step_m: float = 3.0) -> list[float]:
    """Distinct cruise-height offsets (0, +3, +6 m, ...) for shares flown side by side."""
    return [k * step_m for k in range(count)]


def makespan_s(assignments: Sequence[Assignment]) -> float:
    return max((a.estimated_finish_s for a in assignments), default=0.0)


# -- costs ------------------------------------------------------------------------------------
def _to_within(dist: np.ndarray, tol: float, vmax: float, a: float, poll: float) -> np.ndarray:
    """Trapezoidal leg from rest until within ``tol`` (vectorised), on the polling grid."""
    dist = np.asarray(dist, dtype=float)
    total = np.where(dist >= vmax * vmax / a, dist / vmax + vmax / a, 2 * np.sqrt(dist / a))
    ramp = np.minimum(vmax * vmax / (2 * a), dist / 2)  # accelerating (= braking) distance
    x = np.maximum(dist - tol, 0.0)  # where the tolerance is entered
    t = np.where(
        tol <= ramp,
        total - math.sqrt(2 * tol / a),  # while braking
        np.where(x <= ramp, np.sqrt(2 * x / a), vmax / a + (x - ramp) / vmax),
    )
    t = np.where(dist < tol, 0.0, t)
    return np.where(t > 0, np.ceil(t / poll - 1e-9) * poll, 0.0)


def _route(
    route: CoveragePlan | Sequence[LLA], holds_s: Any, altitude_m: float | None, model: VehicleModel
) -> _Route:
    kinds: list[Any]
    if isinstance(route, CoveragePlan):
        waypoints, altitude = (
            route.waypoints,
            route.altitude_m if altitude_m is None else altitude_m,
        )
        steps_of: Callable[[int], list[dict[str, Any]]] = route.unit_steps
        # A waypoint's steps follow from its route point but for where it is (coverage/plan.py).
        what = [f.name for f in fields(RoutePoint) if f.name not in ("x", "y")]
        kinds = list(map(attrgetter(*what), route.points))
        starts = np.array(route.chunk_starts(), dtype=bool)
    else:
        waypoints, altitude = list(route), 10.0 if altitude_m is None else altitude_m
        holds = [holds_s or 0.0] * len(waypoints) if not isinstance(holds_s, Sequence) else holds_s

        def steps_of(i: int) -> list[dict[str, Any]]:
            return _hop(waypoints[i], altitude, holds[i])

        kinds = list(holds)  # a waypoint's steps follow from its hold but for where it is
        starts = np.ones(len(waypoints), dtype=bool)
    if not waypoints:
        raise ValueError("there are no waypoints to share")
    ref = LLA(waypoints[0].lat, waypoints[0].lon)
    lat = np.array([p.lat for p in waypoints], dtype=float)
    lon = np.array([p.lon for p in waypoints], dtype=float)
    north, east = local_frame(ref).horizontal_many(lat, (lon - ref.lon + 180.0) % 360.0 - 180.0)
    xy = np.column_stack((east, north))
    start = LLA(ref.lat, ref.lon, ref.alt_m + altitude)
    # Per unit: its first two steps (navigate, wait_for_flight) are the leg, the rest the hold.
    costs = unit_costs(kinds, lat, lon, steps_of, start, ref, model=model)
    if costs is None:  # units the replay does not cover: every step through the estimator
        costs = _unit_costs_by_estimate(
            [steps_of(i) for i in range(len(waypoints))], start, ref, model
        )
    leg, hold, leg_mah, hold_mah = costs.leg_s, costs.hold_s, costs.leg_mah, costs.hold_mah
    leg[0] = leg_mah[0] = 0.0
    return _Route(xy, leg, hold, leg_mah, hold_mah, starts, altitude, ref)


def _unit_costs_by_estimate(
    units: list[list[dict[str, Any]]], start: LLA, ref: LLA, model: VehicleModel
) -> UnitCosts:
    est = estimate([s for u in units for s in u], start, ref, airborne=True, model=model)
    lengths = np.array([len(u) for u in units])
    first = np.concatenate(([0], np.cumsum(lengths)[:-1]))
    is_leg = np.zeros(int(lengths.sum()), dtype=bool)
    is_leg[first] = is_leg[first + 1] = True
    secs, mah = np.asarray(est.per_step), np.asarray(est.per_step_mah)
    return UnitCosts(
        np.add.reduceat(np.where(is_leg, secs, 0.0), first),
        np.add.reduceat(np.where(is_leg, 0.0, secs), first),
        np.add.reduceat(np.where(is_leg, mah, 0.0), first),
        np.add.reduceat(np.where(is_leg, 0.0, mah), first),
    )


def _start_costs(
    r: _Route, slot: DroneSlot, offset_m: float, model: VehicleModel, climb_while_flying: bool
) -> np.ndarray:
    """Seconds from now until ``slot`` has reached each waypoint (preparation + transit)."""
    here = lla_to_ned(LLA(slot.position.lat, slot.position.lon), r.ref)
    dist = np.hypot(r.xy[:, 0] - here.e, r.xy[:, 1] - here.n)
    cruise = r.altitude_m + offset_m
    height = cruise if slot.home is None else slot.position.alt_m - slot.home.alt_m
    if not slot.airborne:
        height = 0.0
    m = model
    horizontal = _to_within(dist, m.horizontal_tolerance_m, m.max_speed_mps, m.accel_mps2, m.poll_s)
    rate = m.max_climb_mps if cruise >= height else m.max_descent_mps
    climb = abs(cruise - height)
    full_climb = _to_within(np.array([climb]), 1e-3, rate, m.accel_z_mps2, m.poll_s)[0]
    to_tol = _to_within(np.array([climb]), m.vertical_tolerance_m, rate, m.accel_z_mps2, m.poll_s)
    prep = 0.0 if slot.airborne else m.arming_s
    if slot.airborne or climb_while_flying:
        return prep + np.maximum(horizontal, to_tol[0])
    # Take off, wait until at height, then fly (the seed's way); the last metres of the climb
    # finish during the transit.
    return prep + to_tol[0] + np.maximum(horizontal, full_climb - to_tol[0])


# -- the split (the search: allocation_search.py) ---------------------------------------------
def split_route(
    route: CoveragePlan | Sequence[LLA],
    drones: Sequence[DroneSlot],
    *,
    holds_s: float | Sequence[float] | None = None,
    altitude_m: float | None = None,
    altitude_step_m: float = 0.0,
    model: VehicleModel = DEFAULT_MODEL,
    climb_while_flying: bool = True,
    reserve_pct: float = 20.0,
    max_orders: int = 720,
    returns_home: bool = False,
) -> list[Assignment]:
    """Contiguous shares of ``route`` minimising the makespan; in route order.

    ``route`` is a :class:`CoveragePlan` (its mission steps are costed, and fly-through swaths
    are never cut) or ordered waypoints with ``holds_s`` each. Share ``m`` along the route flies
    ``m * altitude_step_m`` higher. A drone that cannot help gets an empty share; no share
    takes its drone below ``reserve_pct`` of battery (ValueError when the fleet cannot). With
    ``returns_home`` (the mission ends with RTL) each drone keeps what its way home from the
    route's farthest waypoint takes (:func:`home_reserve_mah`).
    """
    if not drones:
        raise ValueError("no drones to share the route among")
    r = _route(route, holds_s, altitude_m, model)
    offsets = altitude_offsets(len(drones), altitude_step_m)
    # Shares flown at one height cost the same whatever their place: cost each height once.
    heights = sorted(set(offsets))
    start = np.array(
        [[_start_costs(r, slot, h, model, climb_while_flying) for h in heights] for slot in drones]
    )
    place = [heights.index(off) for off in offsets]
    usable = np.array([(s.battery_pct - reserve_pct) / 100 * model.capacity_mah for s in drones])
    if returns_home:
        route_points = _route_points(route)
        usable -= np.array([home_reserve_mah(route_points, s, r.altitude_m, model) for s in drones])
    search = _Search(r, start, usable, model, place)
    by_distance = sorted(
        range(len(drones)), key=lambda d: float(start[d, 0, 0]) if len(r.xy) else 0.0
    )
    orders = list(itertools.islice(itertools.permutations(by_distance), max_orders))
    lo, hi = _bracket(search, orders, len(drones))
    best = search.feasible(hi, orders)
    if best is None:
        raise ValueError(
            f"the drones' batteries cannot cover the route and keep the {reserve_pct:g}% reserve"
        )
    while hi - lo > max(_PRECISION_S, 1e-4 * hi):
        mid = (lo + hi) / 2
        found = search.feasible(mid, orders)
        if found is None:
            lo = mid
        else:
            hi, best = mid, found
    return _assign(search, drones, best, hi, offsets)


def _bracket(search: _Search, orders: list[tuple[int, ...]], drones: int) -> tuple[float, float]:
    """A lower and an upper bound of the makespan, close enough to save most of a bisection
    from zero to "every share ends by then" (18 rounds to about 10 on the 1 km² field).

    Shares together do all the work but the legs to their first waypoints, so the latest cannot
    end before the work over the drones less the longest leg; an upper bound is looked for
    above that, doubling the margin, and "every share ends by then" is the last resort."""
    r, prefix = search.r, search.prefix
    last = float(search.start.max() + r.hold_s.max() + prefix[-1]) + 1.0  # any share ends by then
    work = float(prefix[-1] + r.hold_s[0])
    lo = max(0.0, work / drones - float(r.leg_s.max()))
    margin = max(float(search.start.min(axis=2).max()), 1.0)
    while lo + margin < last:
        if search.feasible(lo + margin, orders) is not None:
            return lo, lo + margin
        lo, margin = lo + margin, margin * 2.0
    return lo, last


def _assign(
    search: _Search,
    drones: Sequence[DroneSlot],
    order: tuple[int, ...],
    limit: float,
    offsets: list[float],
) -> list[Assignment]:
    reach = [0]
    for m, d in enumerate(order):
        reach.append(search.step(reach[-1], d, m, limit))
    end, chunks = search.n, []
    for m in range(len(order) - 1, -1, -1):
        d = order[m]
        b = search.first_fit(d, m, end, reach[m], limit)
        chunks.append((m, d, b, end))
        end = b
    out = []
    for m, d, b, e in sorted(chunks):
        done = search.finish(d, m, b, e) if e > b else 0.0
        start = search.cost(d, m, b) if e > b else 0.0
        out.append(Assignment(drones[d].drone_id, list(range(b, e)), done, offsets[m], start))
    return out


def seed_equal_split(
    route: CoveragePlan | Sequence[LLA],
    drones: Sequence[DroneSlot],
    *,
    holds_s: float | Sequence[float] | None = None,
    altitude_m: float | None = None,
    model: VehicleModel = DEFAULT_MODEL,
    climb_while_flying: bool = False,
) -> list[Assignment]:
    """The seed's split: equal waypoint counts in route order, drones in the order given (the
    last takes the remainder); finish times costed as :func:`split_route` does."""
    if not drones:
        raise ValueError("no drones to share the route among")
    r = _route(route, holds_s, altitude_m, model)
    start = np.array([[_start_costs(r, s, 0.0, model, climb_while_flying)] for s in drones])
    search = _Search(r, start, np.full(len(drones), np.inf), model, [0] * len(drones))
    size = search.n // len(drones)
    out = []
    for k, slot in enumerate(drones):
        b = k * size
        e = search.n if k == len(drones) - 1 else b + size
        done = search.finish(k, 0, b, e) if e > b else 0.0
        first = float(start[k, 0, b]) if e > b else 0.0
        out.append(Assignment(slot.drone_id, list(range(b, e)), done, 0.0, first))
    return out


def _route_points(route: CoveragePlan | Sequence[LLA]) -> list[LLA]:
    return list(route.waypoints) if isinstance(route, CoveragePlan) else list(route)


def home_reserve_mah(
    points: Sequence[LLA], slot: DroneSlot, altitude_m: float, model: VehicleModel
) -> float:
    """What the way home (RTL, as the vehicle flies it: ground/planner/estimate/) takes from
    the point of ``points`` farthest from ``slot``'s home: kept back from its share's budget."""
    home = slot.home or LLA(slot.position.lat, slot.position.lon, slot.position.alt_m)
    if not points:
        return 0.0
    far = max(points, key=lambda p: lla_to_ned(LLA(p.lat, p.lon, home.alt_m), home).horizontal_m)
    start = LLA(far.lat, far.lon, home.alt_m + altitude_m)
    way_home = [{"command": "rtl"}, {"command": "wait_for_flight"}]
    return estimate(way_home, start, home, airborne=True, model=model).energy_mah


def _hop(p: LLA, altitude_m: float, hold_s: float) -> list[dict[str, Any]]:
    """The steps that fly to one waypoint (and hold there)."""
    steps: list[dict[str, Any]] = [
        {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": altitude_m},
        {"command": "wait_for_flight"},
    ]
    if hold_s:
        steps.append({"command": "sleep", "value": hold_s})
    return steps
