"""Closing a gap by bending one leg of the route through it, instead of flying a spur to it.

:meth:`Detours.cheapest` is the gap filler's first choice for a gap (:mod:`.gaps`): a detour
costs what it adds to the leg, a spur the way out and back. Measured in numpy first, and only
the cheapest few detours that pass are checked in GEOS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString

from dronefleet.ground.planner.coverage.path import XY, Kind, PathBuilder, RoutePoint
from dronefleet.ground.planner.coverage.route import Stroke
from dronefleet.ground.planner.coverage.uncovered import Gap

#: Legs (the cheapest for each way round) tried for a detour through a gap.
DETOUR_LEGS = 4
#: Most detours checked in GEOS for one gap (cheapest first) before a spur closes it.
DETOUR_CHECKS = 6


@dataclass(frozen=True)
class Detours:
    """Detours through gaps for a route whose footprint reaches ``radius_m`` (+ tolerance)."""

    radius_m: float
    tolerance_m: float
    builder: PathBuilder

    def cheapest(
        self,
        points: list[RoutePoint],
        xy: np.ndarray,
        gap: Gap,
        stroke: Stroke,
        cover: shapely.Geometry,
    ) -> tuple[int, list[RoutePoint]] | None:
        """The cheapest way to close ``gap`` by bending one leg of the route through it: leg
        a -> b becomes a -> s0 ... s1 -> b, where s0 -> s1 is ``stroke`` either way round or a
        single point near the gap's tip. A spur from a flies a -> s -> a; the detour costs
        |a s| + |s b| - |a b|, never more (a star's tip from the transit beneath it: 13 m where
        a spur flew 22). The detour must stay inside the area, cover the gap, and not uncover
        what the leg covered (:meth:`_loses`). Returns (leg index, points to insert after
        its start)."""
        if len(xy) < 2:
            return None
        reach = self.radius_m + self.tolerance_m
        a, b = xy[:-1], xy[1:]
        # Never inside a fly-through swath (the camera run); a stopping swath may bend a little
        # towards a gap beside it, if its strip stays covered (checked below).
        kinds = [p.kind for p in points]
        usable = np.array([k is not Kind.SWATH_START for k in kinds[:-1]])
        usable &= np.hypot(*(b - a).T) > 1e-9
        if not usable.any():
            return None
        options, tried = self._options(a, b, usable, gap, stroke)
        if not tried:
            return None
        tried.sort()
        tip = np.asarray(gap.far)
        checked = 0
        dense = shapely.segmentize(gap.shape, 2 * self.tolerance_m)
        edge = np.vstack([np.asarray(r.coords) for r in (dense.exterior, *dense.interiors)])
        limit = self.radius_m + 1.5 * self.tolerance_m
        # Every detour tried at once, as four corners a, s0, s1, b (s0 == s1 for a point: its
        # leg of no length changes no distance): the two quick refusals below in one go.
        picks = np.array([[n, k] for _, n, k in tried])
        ends_all = np.stack(
            [a[picks[:, 1]], *np.moveaxis(np.array(options)[picks[:, 0]], 1, 0), b[picks[:, 1]]],
            axis=1,
        )
        # The gap's tip must be within reach (numpy, before any GEOS).
        near = _distances_each(tip[None, :], ends_all)[:, 0] <= reach
        # One outline sample in COARSE beyond the limit refuses a detour (see _beyond).
        coarse = edge[::COARSE]
        near &= ~(_distances_each(coarse, ends_all) > limit).any(axis=1)
        for (_, n, k), ok in zip(tried, near.tolist(), strict=True):
            if not ok:
                continue
            s0, s1 = options[n]
            ak, bk = (float(a[k][0]), float(a[k][1])), (float(b[k][0]), float(b[k][1]))
            corners = [ak, s0, s1, bk] if s0 != s1 else [ak, s0, bk]
            ends = np.asarray(corners)
            # Every point of the gap's outline within reach (sampled as find_gaps() samples it),
            # and no probe of the leg's strip lost (what the probes miss, a sliver, the next
            # round finds and closes).
            if _beyond(edge, ends, limit):
                continue
            if self._loses(xy, k, ends, cover):
                continue
            checked += 1
            if checked > DETOUR_CHECKS:
                break
            bent = LineString(corners)
            if not cover.covers(bent):
                continue
            extra = self.builder.along(s0, s1)
            if s0 == s1:
                extra = extra[:1]
            return k, extra
        return None

    def _options(
        self, a: np.ndarray, b: np.ndarray, usable: np.ndarray, gap: Gap, stroke: Stroke
    ) -> tuple[list[tuple[XY, XY]], list[tuple[float, int, int]]]:
        """What :meth:`_detour` may fly through the gap, as (s0, s1) pairs, and the legs that
        would take each most cheaply, as (added metres, option, leg)."""
        base = np.hypot(*(b - a).T)
        options: list[tuple[XY, XY]] = [(stroke.start, stroke.end), (stroke.end, stroke.start)]
        tip = np.asarray(gap.far)
        inward = np.asarray(gap.shape.centroid.coords[0]) - tip
        size = float(np.hypot(*inward))
        if size > 1e-9:  # a point just inside the tip, towards the gap's middle
            for pull in (0.9, 0.6):
                p = tip + inward / size * min(pull * self.radius_m, size)
                options.append(((float(p[0]), float(p[1])), (float(p[0]), float(p[1]))))
        tried: list[tuple[float, int, int]] = []
        for n, (s0, s1) in enumerate(options):
            cost = (
                np.hypot(a[:, 0] - s0[0], a[:, 1] - s0[1])
                + math.dist(s0, s1)
                + np.hypot(b[:, 0] - s1[0], b[:, 1] - s1[1])
                - base
            )
            cost = np.where(usable, cost, np.inf)
            for k in np.argsort(cost, kind="stable")[:DETOUR_LEGS].tolist():
                if math.isfinite(cost[k]):
                    tried.append((float(cost[k]), n, k))
        # A small gap beside a leg (a sliver at a corner the leg passes): the leg bent just
        # far enough towards the gap's tip to reach it.
        foot = _feet(a, b, tip)
        off = np.hypot(*(foot - tip).T)
        for k in np.argsort(np.where(usable, off, np.inf), kind="stable")[:DETOUR_LEGS].tolist():
            if not usable[k] or off[k] <= 1e-9:
                continue
            for pull in (0.95, 0.8):
                p = tip + (foot[k] - tip) / off[k] * min(pull * self.radius_m, off[k])
                s = (float(p[0]), float(p[1]))
                options.append((s, s))
                tried.append(
                    (math.dist(a[k], s) + math.dist(s, b[k]) - base[k], len(options) - 1, k)
                )
        return options, tried

    def _loses(self, xy: np.ndarray, k: int, bent: np.ndarray, cover: shapely.Geometry) -> bool:
        """Whether bending leg ``k`` into ``bent`` uncovers part of its strip: probes either
        side of the leg (inside the area) that only the leg reached. In numpy: measuring the
        lost strip in GEOS (buffers, differences) for every detour tried was most of the
        planning time of a star or an arrowhead, and refused no more."""
        reach = self.radius_m + self.tolerance_m
        a, b = xy[k], xy[k + 1]
        d = b - a
        length = float(np.hypot(*d))
        normal = np.array([-d[1], d[0]]) / length
        along = a + np.outer(PROBE_ALONG, d)
        offsets = np.outer(PROBE_ACROSS, normal) * reach
        probes = (along[:, None, :] + offsets[None, :, :]).reshape(-1, 2)
        probes = probes[shapely.contains_xy(cover, probes[:, 0], probes[:, 1])]
        if len(probes) == 0:
            return False
        probes = probes[_distances(probes, bent) > reach]
        if len(probes) == 0:
            return False
        # Only the legs that come within reach of the probes' box can still reach a probe.
        lo, hi = xy[:-1], xy[1:]
        low, high = probes.min(axis=0) - reach, probes.max(axis=0) + reach
        rest = np.all(np.minimum(lo, hi) <= high, axis=1) & np.all(
            np.maximum(lo, hi) >= low, axis=1
        )
        rest[k] = False
        lo, hi = lo[rest], hi[rest]
        if len(lo) == 0:
            return True
        return bool((_distances(probes, np.stack([lo, hi], axis=1)) > reach).any())


#: Where :meth:`Detours._loses` probes a leg: fractions along it, and across it (of reach).
PROBE_ALONG = np.array([0.1, 0.25, 0.4, 0.5, 0.6, 0.75, 0.9])
PROBE_ACROSS = np.array([-0.98, -0.9, -0.75, -0.5, 0.5, 0.75, 0.9, 0.98])


def _distances(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Each point's distance to ``path``: a polyline's corners ((n, 2)) or separate segments
    ((n, 2, 2)). Coordinates apart, and the root taken of the nearest only: summing over a
    last axis of two was most of its time."""
    if path.ndim == 2:
        a, b = path[:-1], path[1:]
    else:
        a, b = path[:, 0], path[:, 1]
    dx, dy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    length2 = np.maximum(dx * dx + dy * dy, 1e-18)
    rx = points[:, 0, None] - a[None, :, 0]
    ry = points[:, 1, None] - a[None, :, 1]
    t = np.clip((rx * dx + ry * dy) / length2, 0.0, 1.0)
    ox, oy = rx - t * dx, ry - t * dy
    return np.sqrt((ox * ox + oy * oy).min(axis=1))


#: Gap outline samples measured first by :func:`_beyond`: one in this many.
COARSE = 16


def _distances_each(points: np.ndarray, polylines: np.ndarray) -> np.ndarray:
    """Each point's distance to each of ``polylines`` ((m, k, 2) corners): an (m, n) array."""
    a, b = polylines[:, None, :-1], polylines[:, None, 1:]  # (m, 1, k - 1, 2)
    dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    length2 = np.maximum(dx * dx + dy * dy, 1e-18)
    rx = points[None, :, None, 0] - a[..., 0]  # (m, n, k - 1)
    ry = points[None, :, None, 1] - a[..., 1]
    t = np.clip((rx * dx + ry * dy) / length2, 0.0, 1.0)
    ox, oy = rx - t * dx, ry - t * dy
    return np.sqrt((ox * ox + oy * oy).min(axis=2))


def _beyond(points: np.ndarray, corners: np.ndarray, limit: float) -> bool:
    """Whether any of ``points`` (a gap's outline, sampled every few centimetres) is farther
    than ``limit`` from the polyline through ``corners``.

    Measuring every sample was half of a traced outline's planning. One in :data:`COARSE` is
    measured first; distance changes no faster than position, so a sample can only be beyond
    ``limit`` if its measured neighbour plus the way between them is, and only those are
    measured too. The answer is the one measuring every sample gives."""
    coarse = np.arange(0, len(points), COARSE)
    d = _distances(points[coarse], corners)
    if bool((d > limit).any()):
        return True
    owner = np.arange(len(points)) // COARSE
    bound = d[owner] + np.hypot(*(points - points[coarse][owner]).T)
    maybe = points[bound > limit]
    return len(maybe) > 0 and bool((_distances(maybe, corners) > limit).any())


def _feet(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The point of each segment ``a[i] -> b[i]`` nearest to ``p``."""
    d = b - a
    length2 = np.maximum((d * d).sum(axis=1), 1e-18)
    t = np.clip(((p - a) * d).sum(axis=1) / length2, 0.0, 1.0)
    return a + t[:, None] * d
