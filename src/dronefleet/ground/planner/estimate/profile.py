"""1-D trapezoidal motion (:class:`Profile`): how the estimator flies a straight leg, or a climb,
in closed form — speed up at the vehicle's acceleration, cruise at its limit, brake onto the
target."""

from __future__ import annotations

import math


class Profile:
    """1-D trapezoidal motion from speed ``s`` towards a target ``d`` metres ahead, then rest."""

    __slots__ = ("d", "phases")

    def __init__(self, d: float, s: float, vmax: float, a: float) -> None:
        self.d = d
        self.phases: list[tuple[float, float, float, float]] = []  # (dur, x0, v0, acc)
        x = 0.0
        if s < 0 or s * s > 2 * a * d + 1e-9:  # moving away, or too fast to stop: brake first
            dur = abs(s) / a
            self._add(dur, x, s, -math.copysign(a, s))
            x += s * dur / 2
            s = 0.0
        rest = d - x
        sign = 1.0 if rest >= 0 else -1.0
        dist = abs(rest)
        peak = min(vmax, math.sqrt(a * dist + s * s / 2))
        peak = max(peak, s)
        d1, d3 = (peak * peak - s * s) / (2 * a), peak * peak / (2 * a)
        t1, t3 = (peak - s) / a, peak / a
        t2 = max(0.0, dist - d1 - d3) / peak if peak > 0 else 0.0
        self._add(t1, x, sign * s, sign * a)
        x += sign * d1
        self._add(t2, x, sign * peak, 0.0)
        x += sign * peak * t2
        self._add(t3, x, sign * peak, -sign * a)

    def _add(self, dur: float, x0: float, v0: float, acc: float) -> None:
        if dur > 0:
            self.phases.append((dur, x0, v0, acc))

    def at(self, t: float) -> tuple[float, float, float]:
        """Position, speed and the integral of speed² over [0, t]."""
        v2 = 0.0
        for dur, x0, v0, acc in self.phases:
            tau = min(t, dur)
            v2 += v0 * v0 * tau + v0 * acc * tau * tau + acc * acc * tau**3 / 3
            if t <= dur:
                return x0 + v0 * tau + acc * tau * tau / 2, v0 + acc * tau, v2
            t -= dur
        return self.d, 0.0, v2

    def time_within(self, tol: float) -> float:
        """First time the distance to the target is below ``tol``."""
        if abs(self.d) < tol:
            return 0.0
        elapsed = 0.0
        for dur, x0, v0, acc in self.phases:
            taus = [_root(x0 - goal, v0, acc / 2, dur) for goal in (self.d - tol, self.d + tol)]
            hits = [tau for tau in taus if tau is not None]
            if hits:
                return elapsed + min(hits)
            elapsed += dur
        return elapsed

    @property
    def duration(self) -> float:
        return sum(p[0] for p in self.phases)


def _root(c: float, b: float, a: float, limit: float) -> float | None:
    """Smallest root in [0, limit] of a·t² + b·t + c (sign change from c)."""
    if abs(a) < 1e-12:
        if abs(b) < 1e-12:
            return None
        t = -c / b
    else:
        disc = b * b - 4 * a * c
        if disc < 0:
            return None
        roots = sorted(((-b - math.sqrt(disc)) / (2 * a), (-b + math.sqrt(disc)) / (2 * a)))
        t = next((r for r in roots if r >= -1e-12), -1.0)
    return max(0.0, t) if -1e-12 <= t <= limit + 1e-12 else None


def rest_to_within_s(distance_m: float, tol_m: float, vmax: float, accel: float) -> float:
    """Time of a leg from rest until within ``tol_m`` of a target ``distance_m`` away."""
    return Profile(distance_m, 0.0, vmax, accel).time_within(tol_m)
