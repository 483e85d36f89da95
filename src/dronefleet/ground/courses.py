"""Where the live separation monitor (ground/separation_monitor.py) expects a drone to be in the
next few seconds, and whether two such courses come within the separation minima.

A drone's telemetry says where it is, how fast it moves, and where it is flying to (its goal:
``goal_lat``/``goal_lon``/``goal_alt_m``, drone/controller.py). A multirotor flies straight to its
goal and stops there (or turns for the next one), so its course is its speed over the ground
along the bearing to the goal until it gets there, and its climb or descent until it reaches the
goal's height. Without a goal it is taken to fly on at its velocity. Velocities alone foresaw
drones on neighbouring 7 m swaths flying on past their turns into each other (three WARNINGs in
the collab experiment, none of them followed by a breach).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

from dronefleet.ground.planner.separation import HORIZONTAL_M, VERTICAL_M

Vector = tuple[float, float, float]  # north, east, up (metres, or metres per second)
#: Slower than this over the ground, a drone is hovering: it is not expected to set off.
HOVER_MPS = 0.2


@dataclass(frozen=True)
class Course:
    """A velocity (n, e, up) held for ``flat_s`` seconds over the ground and ``climb_s`` seconds
    up or down, then stopped."""

    vel: Vector
    flat_s: float = math.inf
    climb_s: float = math.inf

    def velocity_at(self, t: float) -> Vector:
        flat = t < self.flat_s
        return (
            self.vel[0] if flat else 0.0,
            self.vel[1] if flat else 0.0,
            self.vel[2] if t < self.climb_s else 0.0,
        )

    def later(self, dt: float) -> Course:
        """The same course ``dt`` seconds on."""
        return Course(self.vel, self.flat_s - dt, self.climb_s - dt)


def course_to(vel: Vector, to_goal: Vector | None) -> Course:
    """A drone moving at ``vel`` with its goal ``to_goal`` (n, e, up metres) away, or none."""
    if to_goal is None:
        return Course(vel)
    speed = math.hypot(vel[0], vel[1])
    flat_m = math.hypot(to_goal[0], to_goal[1])
    if speed < HOVER_MPS or flat_m < 1e-6:
        flat = Course((0.0, 0.0, 0.0), 0.0)
    else:
        along = (to_goal[0] / flat_m * speed, to_goal[1] / flat_m * speed, 0.0)
        flat = Course(along, flat_m / speed)
    climbing_there = vel[2] * to_goal[2] > 0
    climb_s = abs(to_goal[2] / vel[2]) if climbing_there else math.inf
    return Course((flat.vel[0], flat.vel[1], vel[2]), flat.flat_s, climb_s)


def breach_within(rel: Vector, vel: Vector, horizon_s: float) -> float | None:
    """The first time in [0, horizon_s] at which a relative position ``rel`` (n, e, up) moving at
    ``vel`` is inside the separation cylinder, or None."""
    n, e, u = rel
    vn, ve, vu = vel
    lo, hi = 0.0, horizon_s
    a, b, c = vn * vn + ve * ve, 2 * (n * vn + e * ve), n * n + e * e - HORIZONTAL_M**2
    if a < 1e-12:
        if c >= 0:
            return None
    else:
        disc = b * b - 4 * a * c
        if disc <= 0:
            return None
        root = math.sqrt(disc)
        lo, hi = max(lo, (-b - root) / (2 * a)), min(hi, (-b + root) / (2 * a))
    if abs(vu) < 1e-12:
        if abs(u) >= VERTICAL_M:
            return None
    else:
        t1, t2 = (-VERTICAL_M - u) / vu, (VERTICAL_M - u) / vu
        lo, hi = max(lo, min(t1, t2)), min(hi, max(t1, t2))
    return lo if lo < hi else None


def breach_along(rel: Vector, a: Course, b: Course, horizon_s: float) -> float | None:
    """The first time in [0, horizon_s] at which ``b``, ``rel`` from ``a`` now, is inside the
    separation cylinder, each on its course; None if never."""
    stops = (a.flat_s, a.climb_s, b.flat_s, b.climb_s)
    cuts = sorted({0.0, horizon_s, *(t for t in stops if 0.0 < t < horizon_s)})
    here = rel
    for start, end in itertools.pairwise(cuts):
        va, vb = a.velocity_at(start), b.velocity_at(start)
        vel = (vb[0] - va[0], vb[1] - va[1], vb[2] - va[2])
        hit = breach_within(here, vel, end - start)
        if hit is not None:
            return start + hit
        dt = end - start
        here = (here[0] + vel[0] * dt, here[1] + vel[1] * dt, here[2] + vel[2] * dt)
    return None
