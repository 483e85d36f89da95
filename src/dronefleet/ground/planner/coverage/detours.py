"""Closing a gap by bending one leg of the route through it, instead of flying a spur to it.

:meth:`Detours.cheapest` is the gap filler's first choice for a gap (:mod:`.gaps`): a detour
costs what it adds to the leg, a spur the way out and back. A leg may also keep its line and
send a spike from its point nearest the gap, out and back (a reflex corner's sliver beside a
swath: bending the swath would uncover the far side of its strip; a fly-through swath's camera
run is split at the spike's foot). Measured in numpy first, and only the cheapest few detours
that pass are checked in GEOS.
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
#: What splitting a fly-through swath's camera run for a spike costs beside a bend (m): it
#: stops at the foot and starts again. Without it a concave arrowhead's five 2 m² slivers were
#: closed by split runs rather than bends of the same length, and the quicker route was lost
#: (its estimate 199 -> 220 s); at 10 or 15 m a pond and a dog-leg lost spikes worth 25-65 m.
SPIKE_TURN_M = 5.0
#: A detour adding less than this (m) flies nowhere new, so covers nothing new: a round after
#: a bend through a point, that point was tried again as the end of the leg beside it, and
#: added again round after round while the gap's middle stayed uncovered (a property test).
NO_BEND_M = 1e-6


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
        what the leg covered (:meth:`_orphans`). Returns (leg index, the leg's points: its start and
        end, with the detour between; or, a spike off a fly-through swath, its two runs)."""
        if len(xy) < 2:
            return None
        reach = self.radius_m + self.tolerance_m
        a, b = xy[:-1], xy[1:]
        # Never inside a fly-through swath (the camera run); a stopping swath may bend a little
        # towards a gap beside it, if its strip stays covered (checked below).
        run = np.fromiter((p.kind is Kind.SWATH_START for p in points[:-1]), bool, len(a))
        usable = np.hypot(*(b - a).T) > 1e-9
        if not usable.any():
            return None
        options, tried = self._options(a, b, usable & ~run, usable, gap, stroke)
        tried = sorted(t for t in tried if t[0] > NO_BEND_M)
        if not tried:
            return None
        checked = 0
        edge = gap.sampled(2 * self.tolerance_m)
        limit = self.radius_m + 1.5 * self.tolerance_m
        near, coarse = _screened(a, b, options, tried, gap, edge, (reach, limit))
        beyond = _Beyond(edge, limit)
        orphans: dict[int, np.ndarray] = {}  # each leg's probes no other leg reaches
        for row, ((_, n, k), ok) in enumerate(zip(tried, near.tolist(), strict=True)):
            if not ok:
                continue
            option = options[n]
            ak, bk = (float(a[k][0]), float(a[k][1])), (float(b[k][0]), float(b[k][1]))
            (s0, s1), corners = _bent(option, ak, bk)
            ends = np.asarray(corners)
            # Every point of the gap's outline within reach (sampled as find_gaps() samples it),
            # and no probe of the leg's strip lost (what the probes miss, a sliver, the next
            # round finds and closes).
            if beyond(coarse[row], ends):
                continue
            if k not in orphans:
                orphans[k] = self._orphans(xy, k, cover)
            if _unreached(orphans[k], ends, reach):
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
            if len(option) == 3 and run[k]:  # the camera run stops at the foot, then goes on
                f = option[0]
                return k, [*self.builder.along(ak, f), *extra, *self.builder.along(f, bk)]
            if len(option) == 3:  # back to the foot (a leg's end is a point already)
                foot = RoutePoint(*option[0], Kind.TRANSIT)
                if foot.xy == bk:
                    return k, [points[k], foot, *extra, points[k + 1]]
                extra = [*([foot] if foot.xy != ak else []), *extra, foot]
            return k, [points[k], *extra, points[k + 1]]
        return None

    def _options(
        self,
        a: np.ndarray,
        b: np.ndarray,
        usable: np.ndarray,
        spiked: np.ndarray,
        gap: Gap,
        stroke: Stroke,
    ) -> tuple[list[tuple[XY, ...]], list[tuple[float, int, int]]]:
        """What :meth:`cheapest` may fly through the gap, as (s0, s1) pairs or (foot, s, foot)
        spikes, and the legs that would take each most cheaply, as (added metres, option,
        leg). Pairs bend ``usable`` legs, spikes leave ``spiked`` ones (a fly-through swath's
        too: its camera run is split at the spike's foot)."""
        base = np.hypot(*(b - a).T)
        options: list[tuple[XY, ...]] = [(stroke.start, stroke.end), (stroke.end, stroke.start)]
        tip = np.asarray(gap.far)
        inward = np.asarray(gap.shape.centroid.coords[0]) - tip
        size = float(np.hypot(*inward))
        if size > 1e-9:  # a point just inside the tip, towards the gap's middle
            for pull in (0.9, 0.6):
                p = tip + inward / size * min(pull * self.radius_m, size)
                options.append(((float(p[0]), float(p[1])), (float(p[0]), float(p[1]))))
        tried: list[tuple[float, int, int]] = []
        # Every option's cost on every leg at once (one by one was a tenth of the detours).
        s0, s1 = np.array([o[0] for o in options]), np.array([o[1] for o in options])
        across = np.array([math.dist(p, q) for p, q in options])
        cost = (
            np.hypot(a[None, :, 0] - s0[:, None, 0], a[None, :, 1] - s0[:, None, 1])
            + across[:, None]
            + np.hypot(b[None, :, 0] - s1[:, None, 0], b[None, :, 1] - s1[:, None, 1])
            - base[None, :]
        )
        cost = np.where(usable[None, :], cost, np.inf)
        legs = np.argsort(cost, axis=1, kind="stable")[:, :DETOUR_LEGS]
        best = np.take_along_axis(cost, legs, axis=1)
        for n, (ks, cs) in enumerate(zip(legs.tolist(), best.tolist(), strict=True)):
            tried += [(c, n, k) for k, c in zip(ks, cs, strict=True) if math.isfinite(c)]
        # A small gap beside a leg (a sliver at a corner the leg passes): the leg bent just
        # far enough towards the gap's tip to reach it.
        foot = _feet(a, b, tip)
        off = np.hypot(*(foot - tip).T)
        reach = self.radius_m + self.tolerance_m
        (tx, ty) = gap.far
        # In Python floats (numpy's scalars cost more than the sums; the same sums, the same
        # results).
        for k in np.argsort(np.where(spiked, off, np.inf), kind="stable")[:DETOUR_LEGS].tolist():
            ok, fx, fy = float(off[k]), float(foot[k][0]), float(foot[k][1])
            if not spiked[k] or ok <= 1e-9:
                continue
            ak, bk = (float(a[k][0]), float(a[k][1])), (float(b[k][0]), float(b[k][1]))
            for pull in (0.95, 0.8):
                scale = min(pull * self.radius_m, ok)
                s = (tx + (fx - tx) / ok * scale, ty + (fy - ty) / ok * scale)
                if usable[k]:
                    options.append((s, s))
                    cost = math.dist(ak, s) + math.dist(s, bk) - float(base[k])
                    tried.append((cost, len(options) - 1, k))
                # Or a spike from the leg's point nearest the tip, out and back along the same
                # line: the leg keeps its strip (a reflex corner's sliver beside a swath).
                if ok <= reach:
                    continue  # the leg reaches the tip: a spike would fly nowhere
                options.append(((fx, fy), s, (fx, fy)))
                turns = 0.0 if usable[k] else SPIKE_TURN_M
                tried.append((2.0 * math.dist((fx, fy), s) + turns, len(options) - 1, k))
        return options, tried

    def _loses(self, xy: np.ndarray, k: int, bent: np.ndarray, cover: shapely.Geometry) -> bool:
        """Whether bending leg ``k`` into ``bent`` uncovers part of its strip: a probe of the
        leg's that only the leg reached (:meth:`_orphans`) that ``bent`` does not reach."""
        return _unreached(self._orphans(xy, k, cover), bent, self.radius_m + self.tolerance_m)

    def _orphans(self, xy: np.ndarray, k: int, cover: shapely.Geometry) -> np.ndarray:
        """Probes either side of leg ``k`` (inside the area) that only that leg reaches: a
        detour of the leg must still reach them all, else it uncovers part of its strip. In
        numpy: measuring the lost strip in GEOS (buffers, differences) for every detour tried
        was most of the planning time of a star or an arrowhead, and refused no more. They
        depend on the route only, so they are found once per leg, not once per detour tried
        (a star's detours tried three legs each, and some legs for several options)."""
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
            return probes
        # Only the legs that come within reach of the probes' box can reach a probe.
        lo, hi = xy[:-1], xy[1:]
        low, high = probes.min(axis=0) - reach, probes.max(axis=0) + reach
        rest = np.all(np.minimum(lo, hi) <= high, axis=1) & np.all(
            np.maximum(lo, hi) >= low, axis=1
        )
        rest[k] = False
        lo, hi = lo[rest], hi[rest]
        if len(lo) == 0:
            return probes
        return probes[_distances(probes, np.stack([lo, hi], axis=1)) > reach]


#: Where :meth:`Detours._orphans` probes a leg: fractions along it, and across it (of reach).
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


#: Gap outline samples measured first by :class:`_Beyond`: one in this many.
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


def _screened(
    a: np.ndarray,
    b: np.ndarray,
    options: list[tuple[XY, ...]],
    tried: list[tuple[float, int, int]],
    gap: Gap,
    edge: np.ndarray,
    limits: tuple[float, float],
) -> tuple[np.ndarray, np.ndarray]:
    """The two quick refusals of :meth:`Detours.cheapest`, for every detour tried at once (as
    four corners a, s0, s1, b; s0 == s1 for a point: its leg of no length changes no
    distance): whether each reaches the gap's tip and no sample of its outline in COARSE is
    beyond the limit; and those samples' distances, which :class:`_Beyond` goes on from."""
    reach, limit = limits
    picks = np.array([[n, k] for _, n, k in tried])
    # Padded to three points (a pair's last repeated: a leg of no length changes nothing).
    padded = np.array([(*o, o[-1]) if len(o) == 2 else o for o in options])
    ends_all = np.stack(
        [a[picks[:, 1]], *np.moveaxis(padded[picks[:, 0]], 1, 0), b[picks[:, 1]]], axis=1
    )
    # The gap's tip must be within reach (numpy, before any GEOS); the outline is measured
    # only for the detours that reach it (a few of some thirty tried).
    near = _distances_each(np.asarray(gap.far)[None, :], ends_all)[:, 0] <= reach
    samples = edge[::COARSE]
    coarse = np.full((len(tried), len(samples)), np.inf)
    if near.any():
        coarse[near] = _distances_each(samples, ends_all[near])
    return near & ~(coarse > limit).any(axis=1), coarse


def _bent(option: tuple[XY, ...], a: XY, b: XY) -> tuple[tuple[XY, XY], list[XY]]:
    """What a detour flies through the gap (s0 to s1) and the corners of leg ``a -> b`` bent
    through ``option``: a pair (s0, s1), or a spike (foot, s, foot) out and back."""
    if len(option) == 3:  # a spike: out from the leg to the gap and back
        return (option[1], option[1]), [a, *option, b]
    s0, s1 = option[0], option[-1]
    return (s0, s1), [a, s0, s1, b] if s0 != s1 else [a, s0, b]


def _unreached(probes: np.ndarray, corners: np.ndarray, reach: float) -> bool:
    """Whether any of ``probes`` is farther than ``reach`` from the polyline ``corners``."""
    return len(probes) > 0 and bool((_distances(probes, corners) > reach).any())


def _beyond(points: np.ndarray, corners: np.ndarray, limit: float) -> bool:
    """Whether any of ``points`` (a gap's outline) is farther than ``limit`` from the polyline
    through ``corners`` (:class:`_Beyond`, measuring one sample in COARSE first)."""
    return _Beyond(points, limit)(_distances(points[::COARSE], corners), corners)


class _Beyond:
    """Whether any point of a gap's outline (sampled every few centimetres) is farther than
    ``limit`` from a polyline, given the distances of one sample in :data:`COARSE`.

    Measuring every sample was half of a traced outline's planning. Distance changes no faster
    than position, so a sample can only be beyond ``limit`` if its measured neighbour plus the
    way between them is, and only those are measured too. The answer is the one measuring every
    sample gives. The way from each sample to its measured neighbour is the same for every
    detour of a gap: it is computed once."""

    def __init__(self, points: np.ndarray, limit: float) -> None:
        self.points, self.limit = points, limit
        self.owner = np.arange(len(points)) // COARSE
        self.spread = np.hypot(*(points - points[::COARSE][self.owner]).T)

    def __call__(self, coarse: np.ndarray, corners: np.ndarray) -> bool:
        if bool((coarse > self.limit).any()):
            return True
        maybe = self.points[coarse[self.owner] + self.spread > self.limit]
        return len(maybe) > 0 and bool((_distances(maybe, corners) > self.limit).any())


def _feet(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The point of each segment ``a[i] -> b[i]`` nearest to ``p``."""
    d = b - a
    length2 = np.maximum((d * d).sum(axis=1), 1e-18)
    t = np.clip(((p - a) * d).sum(axis=1) / length2, 0.0, 1.0)
    return a + t[:, None] * d
