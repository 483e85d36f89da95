"""Predicted separation between drones (issue 14): two paths in time, and where they come close.

The rule (docs/DESIGN.md §12): two drones in the air are in conflict when they are closer than
:data:`HORIZONTAL_M` horizontally **and** closer than :data:`VERTICAL_M` vertically at the same
time, the cylinder around each drone that manned aviation's separation minima use, scaled down
to small multirotors flying a few metres apart. A drone on the ground is not traffic (where
drones are parked is the operator's choice; two drones parked 3 m apart are not a conflict, two
climbing out of there at once are).

Paths come from :mod:`.trajectory` on one uniform time grid. Between two samples each drone is
taken to fly straight at constant speed, so the relative position is linear in time and the
check is exact on it: the times at which the horizontal distance is below the minimum (a
quadratic) and those at which the vertical one is (linear) are intersected per interval, all
intervals at once with numpy. A crossing at 20 m/s closing speed is caught however short it is.

Why by hand: shapely and the like answer "do these shapes meet", not "are these two moving
points ever inside one cylinder at the same time"; the closed form is a dozen lines.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from dronefleet.errors import InvalidInput
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.orphans import keep_out_of
from dronefleet.ground.planner.trajectory import SAMPLE_S, Trajectory

#: The separation minima: closer than both at once is a conflict.
HORIZONTAL_M = 5.0
VERTICAL_M = 3.0
#: A plan keeps the minima even if either drone runs this many seconds early or late (a
#: command's latency, a position a heartbeat old, a wind the model does not know): each path is
#: also compared with the other shifted by this much both ways.
TIMING_SLACK_S = 2.0


@dataclass(frozen=True)
class Conflict:
    """Two drones predicted too close: when (vehicle s from now), where, and how close."""

    drone_a: str
    drone_b: str
    t_s: float
    position: LLA  # midway between the two
    horizontal_m: float
    vertical_m: float
    minimum_m: float = HORIZONTAL_M  # the horizontal minimum there (more from a lost drone)
    lost: str | None = None  # which of the two is a lost drone (ground/planner/orphans.py)

    def describe(self) -> str:
        lost = f" ({self.lost} is lost: its last place is kept clear)" if self.lost else ""
        return (
            f"drones {self.drone_a} and {self.drone_b} would be {self.horizontal_m:.1f} m apart"
            f" horizontally and {self.vertical_m:.1f} m vertically {self.t_s:.1f} s after the"
            f" start, at {self.position.lat:.6f}, {self.position.lon:.6f},"
            f" {self.position.alt_m:.1f} m (minimum {self.minimum_m:.3g} m horizontally or"
            f" {VERTICAL_M:g} m vertically){lost}"
        )


class SeparationConflict(InvalidInput):
    """A plan that would bring two drones too close and could not be deconflicted (REST: 422)."""

    def __init__(self, conflict: Conflict, tried: str = "") -> None:
        self.conflict = conflict
        self.tried = tried
        message = f"separation: {conflict.describe()}"
        super().__init__(message + (f"; {tried}" if tried else ""))

    def __reduce__(self) -> tuple[Any, ...]:
        # Raised in the planning worker's process and unpickled in the ground's: rebuilt from
        # what it was made of (by default from its message, which is not a Conflict; the pool
        # then broke for good and the ground could plan nothing more: issue 26).
        return (type(self), (self.conflict, self.tried))


def _interval_hits(
    dn: np.ndarray,
    de: np.ndarray,
    du: np.ndarray,
    both_up: np.ndarray,
    radius: np.ndarray | float = HORIZONTAL_M,
) -> tuple[np.ndarray, np.ndarray]:
    """Per interval k (samples k..k+1): whether the relative motion enters the cylinder (of
    ``radius``, per interval), and the fraction of the interval at which it first does."""
    return _segment_hits(dn[:-1], dn[1:], de[:-1], de[1:], du[:-1], du[1:], both_up, radius)


def _segment_hits(
    n0: np.ndarray,
    n1: np.ndarray,
    e0: np.ndarray,
    e1: np.ndarray,
    u0: np.ndarray,
    u1: np.ndarray,
    both_up: np.ndarray,
    radius: np.ndarray | float = HORIZONTAL_M,
) -> tuple[np.ndarray, np.ndarray]:
    """Per straight relative segment (n0, e0, u0) -> (n1, e1, u1): whether it enters the
    cylinder (of ``radius``), and the fraction of the segment at which it first does."""
    sn, se, su = n1 - n0, e1 - e0, u1 - u0
    # Horizontal: |(n0, e0) + s (sn, se)|² < R²  <=>  a s² + b s + c < 0.
    a = sn * sn + se * se
    b = 2.0 * (n0 * sn + e0 * se)
    c = n0 * n0 + e0 * e0 - np.square(radius)
    disc = b * b - 4.0 * a * c
    moving = a > 1e-12
    root = np.sqrt(np.where(disc > 0, disc, 0.0))
    safe_a = np.where(moving, a, 1.0)
    h_lo = np.where(moving, (-b - root) / (2 * safe_a), np.where(c < 0, 0.0, np.inf))
    h_hi = np.where(moving, (-b + root) / (2 * safe_a), np.where(c < 0, 1.0, -np.inf))
    h_lo = np.where(moving & (disc <= 0), np.inf, h_lo)
    h_hi = np.where(moving & (disc <= 0), -np.inf, h_hi)
    # Vertical: |u0 + s su| < V.
    climbing = np.abs(su) > 1e-12
    safe_su = np.where(climbing, su, 1.0)
    s1 = (-VERTICAL_M - u0) / safe_su
    s2 = (VERTICAL_M - u0) / safe_su
    inside = np.abs(u0) < VERTICAL_M
    v_lo = np.where(climbing, np.minimum(s1, s2), np.where(inside, 0.0, np.inf))
    v_hi = np.where(climbing, np.maximum(s1, s2), np.where(inside, 1.0, -np.inf))
    lo = np.maximum.reduce([h_lo, v_lo, np.zeros_like(a)])
    hi = np.minimum.reduce([h_hi, v_hi, np.ones_like(a)])
    return (lo < hi) & both_up, lo


def first_conflict(a: Trajectory, b: Trajectory, *, origin: LLA) -> Conflict | None:
    """The first moment ``a`` and ``b`` are predicted inside each other's cylinder, or None.

    Each path holds its last sample after it ends (hovering or parked), so the comparison runs
    to the end of the longer one."""
    length = max(len(a.n_m), len(b.n_m), 2)
    a, b = a.padded(length), b.padded(length)
    dn, de, du = a.n_m - b.n_m, a.e_m - b.e_m, a.up_m - b.up_m
    up = a.in_air & b.in_air
    radius = minimum_m(a, b)
    hits, entry = _interval_hits(dn, de, du, up[:-1] & up[1:], radius)
    if not hits.any():
        return None
    k = int(np.argmax(hits))
    # Reported at its closest: the sample of the encounter (its run of intervals in conflict)
    # nearest horizontally while within the vertical minimum, else where it began.
    end = k + int(np.argmin(hits[k:])) if not hits[k:].all() else len(hits)
    flat = np.hypot(dn[k : end + 1], de[k : end + 1])
    flat = np.where(np.abs(du[k : end + 1]) < VERTICAL_M, flat, np.inf)
    if np.isfinite(flat).any():
        k, s = k + int(np.argmin(flat)), 0.0
    else:
        s = float(entry[k])
    t_s = (k + s) * SAMPLE_S

    def lerp(x: np.ndarray) -> float:
        return float(x[k]) if s == 0.0 else float(x[k] + s * (x[k + 1] - x[k]))

    mid = NED(
        (lerp(a.n_m) + lerp(b.n_m)) / 2,
        (lerp(a.e_m) + lerp(b.e_m)) / 2,
        -(lerp(a.up_m) + lerp(b.up_m)) / 2,
    )
    lost = next((p.drone_id for p in (b, a) if keep_out_of(p) is not None), None)
    return Conflict(
        a.drone_id,
        b.drone_id,
        round(t_s, 1),
        ned_to_lla(mid, origin),
        horizontal_m=float(np.hypot(lerp(dn), lerp(de))),
        vertical_m=abs(lerp(du)),
        minimum_m=_at(radius, k),
        lost=lost,
    )


def _at(radius: np.ndarray | float, k: int) -> float:
    if isinstance(radius, np.ndarray):
        return float(radius[min(k, len(radius) - 1)])
    return float(radius)


def minimum_m(a: Trajectory, b: Trajectory) -> np.ndarray | float:
    """The horizontal minimum between ``a`` and ``b`` (padded alike), per interval: the
    separation minimum, or more from a lost drone (:func:`.orphans.keep_out_of`)."""
    kept = [k for k in (keep_out_of(a), keep_out_of(b)) if k is not None]
    if not kept:
        return HORIZONTAL_M
    length = len(a.n_m)
    radius = np.full(max(length - 1, 1), HORIZONTAL_M)
    for k in kept:
        k = np.concatenate([k, np.full(max(0, length - len(k)), k[-1])])[:length]
        radius = np.maximum(radius, np.maximum(k[:-1], k[1:]) if length > 1 else k[:1])
    return radius


#: Seconds ahead the live monitor extrapolates velocities (ground/separation_monitor.py).
WARNING_HORIZON_S = 3.0


def first_conflict_with_slack(
    a: Trajectory, b: Trajectory, *, origin: LLA, slack_s: float = TIMING_SLACK_S
) -> Conflict | None:
    """:func:`first_conflict` of ``a`` with ``b`` on time, and with ``b`` ``slack_s`` early and
    late; the on-time one is reported when there is one."""
    for other in (b, b.delayed(slack_s), b.advanced(slack_s)) if slack_s > 0 else (b,):
        hit = first_conflict(a, other, origin=origin)
        if hit is not None:
            return hit
    return None


def closest_approach(a: Trajectory, b: Trajectory) -> tuple[float, float]:
    """The smallest horizontal distance between ``a`` and ``b`` while both are in the air and
    within :data:`VERTICAL_M` of each other, and the smallest 3-D distance while both are in
    the air (inf when never): figures for tests and reports, on the samples."""
    length = max(len(a.n_m), len(b.n_m))
    a, b = a.padded(length), b.padded(length)
    up = a.in_air & b.in_air
    if not up.any():
        return float("inf"), float("inf")
    dn, de, du = (a.n_m - b.n_m)[up], (a.e_m - b.e_m)[up], (a.up_m - b.up_m)[up]
    flat = np.hypot(dn, de)
    near = np.abs(du) < VERTICAL_M
    return (
        float(flat[near].min()) if near.any() else float("inf"),
        float(np.sqrt(flat * flat + du * du).min()),
    )


def conflicts(trajectories: list[Trajectory], *, origin: LLA) -> list[Conflict]:
    """Every pair's first conflict, earliest first."""
    found = []
    for i, a in enumerate(trajectories):
        for b in trajectories[i + 1 :]:
            hit = first_conflict(a, b, origin=origin)
            if hit is not None:
                found.append(hit)
    return sorted(found, key=lambda c: c.t_s)
