"""The automatic swath angle, first keyed quickly: fewest swath segments (turns), then least
total swath length. The key only shortlists (:meth:`AngleChooser.shortlist`: the best keys, the
best hull side and the direction across it); the pipeline plans a route for each and flies the
quickest (:mod:`.pipeline`, :mod:`.cost`), since the key cannot see transits or gaps.

Trying the direction of every convex-hull edge (the optimum for a convex area is parallel to one
of them) made the search as long as the outline: a traced 2000-vertex circle took a minute. The
search here is bounded whatever the outline, and never worse than a fixed set of directions:

* the hull is first simplified (a few centimetres) so that a traced side counts as the one
  straight side it draws, not as hundreds of jittered pieces;
* the directions carrying the most hull length are tried (``hull_directions`` of them: every
  side of an ordinary field, whose few hull edges are all tried as before), and every
  ``step_deg`` degrees;
* the best few are refined by a pattern search (half the step, then a quarter, ...) that only
  moves to strictly better angles — the coarse-to-fine part, which finds the narrow optimum of
  a shape without dominant sides (a circle, a gear) that neither list holds.

Scoring an angle is a numpy scanline (:mod:`.clip`) over the outline simplified to a
hundredth of the spacing, so the search costs some 60 scorings of well under a millisecond.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from shapely.geometry import Polygon

from dronefleet.ground.planner.coverage.clip import counts, edges_of, rotated
from dronefleet.ground.planner.coverage.swaths import SwathGenerator

#: Hull simplification, as a fraction of the hull's size (1 m on a 1 km field).
HULL_TOLERANCE = 1e-3

#: Outline simplification for scoring angles, as a fraction of the spacing (10 cm at 10 m).
SCORE_TOLERANCE = 0.01

Key = tuple[int, float]

#: Shortlisted angles closer than this (degrees) give nearly the same route: one is enough.
SAME_DEG = 2.0
#: Hull sides are kept unless this close (degrees) to an angle already listed: a traced side
#: comes as several pieces a hair apart.
SAME_SIDE_DEG = 0.01


def simplified(area: Polygon, tolerance_m: float) -> Polygon:
    """``area`` without the detail a swath cannot see (vertices within ``tolerance_m`` of the
    line through their neighbours), for scoring angles only.

    A traced outline carries far more vertices than a 10 m swath pattern can tell apart, and a
    scoring's cost grows with them. The angle only compares counts and lengths of swaths, which
    move by a few centimetres at most, so it is scored on the simplified outline (shapely, a
    dependency already). The route itself is planned on the exact outline: a simplified one
    may bulge outside it by the tolerance, and no leg may leave the area."""
    simple = area.simplify(tolerance_m, preserve_topology=True)
    if simple.geom_type != "Polygon" or simple.is_empty or not simple.is_valid:
        return area
    return simple


@dataclass(frozen=True)
class AngleChooser:
    step_deg: float = 15.0
    hull_directions: int = 16
    refine: int = 3  # best angles refined
    levels: int = 5  # halvings of the step around each (15° -> 0.47°)
    sides_kept: int = 2  # hull sides always in the shortlist

    def hull_candidates(self, area: Polygon) -> list[float]:
        """Directions of the hull's sides, longest (summed per direction) first."""
        hull = area.convex_hull
        if hull.geom_type != "Polygon":
            return []
        minx, miny, maxx, maxy = hull.bounds
        simple = hull.simplify(HULL_TOLERANCE * max(maxx - minx, maxy - miny))
        if simple.geom_type == "Polygon" and not simple.is_empty:
            hull = simple
        xy = np.asarray(hull.exterior.coords)
        d = np.diff(xy, axis=0)
        length = np.hypot(d[:, 0], d[:, 1])
        keep = length > 1e-6
        angles = np.round(np.degrees(np.arctan2(d[keep, 0], d[keep, 1])) % 180.0, 6)
        weight: dict[float, float] = {}
        for a, w in zip(angles.tolist(), length[keep].tolist(), strict=True):
            weight[a] = weight.get(a, 0.0) + w
        ranked = sorted(weight, key=lambda a: -weight[a])  # stable: hull order among equals
        return ranked[: self.hull_directions]

    def candidates(self, area: Polygon) -> list[float]:
        steps = round(180.0 / self.step_deg)
        angles = self.hull_candidates(area) + [k * self.step_deg for k in range(steps)]
        return list(dict.fromkeys(angles))  # hull sides first, no duplicates

    @staticmethod
    def score(edges: np.ndarray, swaths: SwathGenerator, angle: float) -> Key:
        turned = rotated(edges, angle)
        ys = np.asarray(swaths.offsets(float(turned[:, 1].min()), float(turned[:, 1].max())))
        segments, length = counts(turned, ys)
        return segments, round(length, 3)

    def choose(self, area: Polygon, swaths: SwathGenerator) -> float:
        """The angle of fewest swath segments, then least swath length (the quick key)."""
        return self._search(area, swaths)[1]

    def shortlist(self, area: Polygon, swaths: SwathGenerator, size: int) -> list[float]:
        """Up to ``size`` angles worth planning a route for, best quick key first.

        The quick key counts turns and swath length but not what the route adds: transits round
        a pond, spurs into the corners a slightly turned swath misses. A 400 x 12 m strip keyed
        best at 0.96° off its sides (the same two swaths, a little shorter) and then needed spurs
        at both ends: 1059 m instead of 811 m. So the list holds the best hull side too and the
        direction across it (a five-pointed star's tip-up axis: 610 m where its sides gave 639),
        and the pipeline picks among them by the routes' flying time (:mod:`.cost`)."""
        scored, best = self._search(area, swaths)
        ranked = sorted(scored, key=lambda a: scored[a])
        hull = set(self.hull_candidates(area))
        sides = [a for a in ranked if a in hull]
        picks: list[float] = [best]
        # A side 1° from the best key may be the better route (the strip); across the best side
        # lies a star's axis of symmetry, and a rectangle's other side.
        across = [round((sides[0] + 90.0) % 180.0, 6)] if sides else []
        for angle in [*sides[:1], *across, *sides[1 : self.sides_kept]]:
            if len(picks) >= size:
                break
            if all(_apart(angle, p) > SAME_SIDE_DEG for p in picks):
                picks.append(angle)
        for angle in ranked:
            if len(picks) >= size:
                break
            if all(_apart(angle, p) > SAME_DEG for p in picks):
                picks.append(angle)
        return picks

    def _search(self, area: Polygon, swaths: SwathGenerator) -> tuple[dict[float, Key], float]:
        edges = edges_of(simplified(area, SCORE_TOLERANCE * swaths.spacing_m))
        scored: dict[float, Key] = {}

        def key(angle: float) -> Key:
            angle = round(angle % 180.0, 6)
            if angle not in scored:
                scored[angle] = self.score(edges, swaths, angle)
            return scored[angle]

        for angle in self.candidates(area):
            key(angle)
        best_angle = min(scored, key=lambda a: scored[a])  # first of equals: candidate order
        seeds = sorted(scored, key=lambda a: scored[a])[: self.refine]
        for seed in seeds:
            here, delta = seed, self.step_deg / 2.0
            for _ in range(self.levels):
                for trial in (here - delta, here + delta):
                    if key(trial) < key(here):
                        here = round(trial % 180.0, 6)
                delta /= 2.0
            if key(here) < key(best_angle):
                best_angle = here
        return scored, best_angle


def _apart(a: float, b: float) -> float:
    """Degrees between two swath directions (modulo 180)."""
    d = abs(a - b) % 180.0
    return min(d, 180.0 - d)
