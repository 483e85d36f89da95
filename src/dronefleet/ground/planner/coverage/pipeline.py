"""The coverage pipeline: the Mission Planner's mapping feature (seed 4.2.4, Figure 4.27).

Named stages, each a small object that can be swapped or tested alone (STYLE.md, after
Fields2Cover): project to a local plane → shortlist angles → for each, swath lines → boustrophedon
cells → route over the whole field (solver, transits inside the area) → path (waypoints) → close
the gaps up to the coverage target → keep the angle whose route flies quickest (then shortest) →
below a 100 % target, pull its ends in (:mod:`.ends`) → back to LLA. ``plan_area(spec)`` runs
the default pipeline. Small areas are also offered rings (:mod:`.contour`) and a headland,
the outline flown once and swaths inside it (:mod:`.headland`), where those are chosen.

Planning a route for every angle tried would be slow, so angles are first keyed quickly
(:mod:`.angle`: turns and swath length) and only a shortlist — the best key, the best hull side
and the direction across it — is routed and timed (:mod:`.cost`); the gaps are closed for the
two likeliest only (:meth:`CoveragePipeline._search`). The shortlist shrinks on large areas, so
that a square kilometre at 10 m plans and splits among 10 drones within the fleet's budget of
200 ms (bench/coverage_vs_f2c.py fleet).

The planning time this costs (bench/coverage_vs_f2c.py, CPU time on a shared 2-core machine at a
load of 6 to 14): 11-98 ms for the bench's fields up to 9 ha before gaps were closed by detours
(:mod:`.gaps`), where the cell-by-cell planner took 4-31 ms there and Fields2Cover 197-492 ms on
the tester's. The detours cost the small, gappy fields two to four times that (a star about 100
-> 290 ms, measured side by side at a load near 20) for 5-15 % shorter paths. Since then the
small fields no longer weave strokes as well, a second angle's closing stops once it cannot win,
and the filler starts from the gaps the guess found: side by side at a load of 8 to 13, a star
200 -> 125 ms, an arrowhead 215 -> 120, a dog-leg 180 -> 85, a traced outline 310 -> 240 (stop
mode). Since then an angle that can no longer be flown is not closed, or stops being closed,
by its length too (:func:`~.candidate.beaten`), an angle slower before its gaps than two guesses
is not guessed, and the detours measure what does not change once per gap: alternating with the
code before at a load of 3 to 5 (the best of ten runs, each the best of three), a traced outline
179 -> 116 ms, a star 84 -> 73, a pond 50 -> 37, a dog-leg 64 -> 50 (stop mode), the same
routes; the farm and the 9 ha field, which close their gaps without detours, 99 -> 91 and 81 ->
75. The route is bounded by the solver's move and round limits (:mod:`.solver`) and the
filler's rounds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import LineString, Point, Polygon

from dronefleet.ground.planner.coverage.angle import AngleChooser
from dronefleet.ground.planner.coverage.candidate import (
    Candidate,
    Over,
    beaten,
    chosen,
    quicker_live,
    route_length,
)
from dronefleet.ground.planner.coverage.cost import RouteTime
from dronefleet.ground.planner.coverage.decompose import BoustrophedonDecomposer
from dronefleet.ground.planner.coverage.ends import trimmed
from dronefleet.ground.planner.coverage.gaps import SLIVER_SPACINGS, GapFiller
from dronefleet.ground.planner.coverage.outlines import (
    DETOUR_SQUARES,
    or_contour,
    or_headland,
    vertices,
)
from dronefleet.ground.planner.coverage.path import PathBuilder, RoutePoint, route_xy
from dronefleet.ground.planner.coverage.plan import PICTURE_S, CoveragePlan
from dronefleet.ground.planner.coverage.project import LocalProjection
from dronefleet.ground.planner.coverage.route import Pass, Routed, WholeFieldOrderer
from dronefleet.ground.planner.coverage.spec import Action, AreaSpec, Grid
from dronefleet.ground.planner.coverage.swaths import (
    SwathGenerator,
    from_sweep_xy,
    to_sweep,
)

#: Most waypoints (or pictures) one area may ask for; a mission holds at most 10 000 steps.
MAX_WAYPOINTS = 20_000
#: Gap tolerance as a fraction of the spacing: a point may be this much beyond half a spacing.
GAP_TOLERANCE = 0.002
#: Angles planned to the end, by the area's size in spacing-squares (spacing x spacing): a 10 ha
#: field at 10 m is 1000 of them. Each route costs about a millisecond per 100 squares.
SHORTLIST = ((500, 3), (3_000, 2))
#: Shortlisted angles also tried with one line fewer when the target allows it (the first few).
FEWER_AT = 2
#: Outlines with more vertices than this are traced ones: a single angle is planned.
TRACED_VERTICES = 400
#: Most angles whose gaps are closed (see CoveragePipeline._search).
CLOSED = 2
#: Most swaths a route may have for its gaps to be closed by strokes the solver weaves in (a
#: second solve and path); past that a gap costs little beside the route, and spurs do.
STROKES_UP_TO = 60


@dataclass(frozen=True)
class CoveragePipeline:
    angles: AngleChooser = field(default_factory=AngleChooser)
    decomposer: BoustrophedonDecomposer = field(default_factory=BoustrophedonDecomposer)
    orderer: WholeFieldOrderer = field(default_factory=WholeFieldOrderer)
    timing: RouteTime = field(default_factory=RouteTime)
    fill_gaps: bool = True
    contours: bool = True  # small areas may be flown ring by ring (:mod:`.contour`)
    headlands: bool = True  # or along the outline once, then in swaths (:mod:`.headland`)
    detours: bool = True  # gaps closed by bending the route's legs, not by spurs alone

    def plan(self, spec: AreaSpec) -> CoveragePlan:
        projection = LocalProjection.around(spec)
        area = projection.area(spec)
        spacing = spec.line_spacing_m
        expected = area.area / (spacing * (spec.trigger_m if spec.fly_through else spacing))
        if expected > MAX_WAYPOINTS:
            raise ValueError(
                f"{area.area:.0f} m² at {spacing:g} m spacing needs about {expected:.0f}"
                f" {'pictures' if spec.fly_through else 'waypoints'} (at most {MAX_WAYPOINTS});"
                " widen the spacing or split the area"
            )
        swaths = SwathGenerator(spacing, spec.grid)
        if spec.angle_deg is not None:
            angles = [spec.angle_deg]
        else:
            angles = self.angles.shortlist(area, swaths, shortlist_size(area, spacing))
        first = projection.to_xy(*spec.polygon[0])
        layouts = [swaths]
        if spec.coverage_target_pct < 100.0 and spec.grid == Grid.INSET:
            layouts.append(replace(swaths, fewer=1))  # one line less, if the target allows
        laid = [
            self.layout(spec, area, lines, a % 360.0, first)
            for k, a in enumerate(angles)
            for lines in layouts[: 1 if k >= FEWER_AT else None]  # one line fewer: the likeliest
        ]
        found = [c for c in laid if c is not None]
        if not found:
            raise ValueError(f"the area is too small for swaths {spacing:g} m apart")
        filler = self.filler(spec, area, swaths.spacing_m)
        if len(found) == 1:
            self.route(spec, found[0], timed=False)
            if filler is not None:
                self.close_gaps(found[0], filler)
            best = found[0]
        else:
            best = self._search(spec, found, filler)
        if self.contours and spec.angle_deg is None and spec.grid == Grid.INSET:
            best = or_contour(self, spec, area, first, best, filler)
        if self.headlands and spec.angle_deg is None and spec.grid == Grid.INSET:
            best = or_headland(self, spec, area, first, best, filler)
        if filler is not None:  # after the choice: pulling a route's ends in only shortens it
            ends = replace(filler, builder=best.builder)
            best.points, best.left = trimmed(best.points, best.sweep_area, best.left, ends)
        assert best.routed is not None
        angle = best.angle
        local, xy = _unrotate(best.points, angle)
        waypoints = projection.to_lla_many(xy, spec.altitude_m)
        left = [affinity.rotate(g, 90.0 - angle, origin=(0.0, 0.0)) for g in best.left]
        return CoveragePlan(
            spec=spec,
            origin=projection.origin,
            angle_deg=angle,
            spacing_m=spacing,
            trigger_distance_m=(spec.trigger_m if spec.fly_through else 0.0) or None,
            local_polygon=area,
            swaths=[
                LineString([from_sweep_xy(*p.start, angle), from_sweep_xy(*p.end, angle)])
                for p in best.routed.passes
                if isinstance(p, Pass) or best.pattern != "swaths"  # a ring's sides are passes
            ],
            points=local,
            waypoints=waypoints,
            uncovered_m2=float(sum(g.area for g in left)),
            cells=len(best.cells),
            uncovered=left,
            uncovered_rings=[_rings(projection, g) for g in left],
            pattern=best.pattern,
        )

    def layout(
        self,
        spec: AreaSpec,
        area: Polygon,
        swaths: SwathGenerator,
        angle: float,
        first: tuple[float, float],
    ) -> Candidate | None:
        """The swaths and cells at ``angle``; None when no swath fits (or, one line fewer, when
        the strips left would be more than the target allows)."""
        spacing = swaths.spacing_m
        sweep_area: Polygon = to_sweep(area, angle)
        lines = swaths.lines(sweep_area)
        if swaths.fewer:
            swept = spacing * sum(b - a for line in lines for a, b in line.segments)
            if area.area - swept > (1.0 - spec.coverage_target_pct / 100.0) * area.area:
                return None
        cells = self.decomposer.cells(lines)
        if not cells:
            return None
        start = to_sweep(Point(first), angle).coords[0]
        photo = spec.action == Action.TAKEPIC
        trigger = spec.trigger_m if spec.fly_through else 0.0
        # On the footprint grid, stops that do something are made at the centres of the cells.
        centres = spec.grid == Grid.INSET and spec.action != Action.NONE
        builder = PathBuilder(spacing, spec.fly_through, trigger, photo, centres)
        return Candidate(angle, sweep_area, cells, builder, start, hold_s=_hold_s(spec))

    def route(self, spec: AreaSpec, c: Candidate, timed: bool = True) -> None:
        """``c``'s route over the whole field and its points; gaps not yet closed."""
        routed = c.routed = self.orderer.order(c.cells, c.start, c.sweep_area)
        c.points = c.builder.build(routed.passes, routed.transits)
        if timed:
            self._cost(spec, c)
            c.guess = c.time_s

    def _search(
        self, spec: AreaSpec, found: list[Candidate], filler: GapFiller | None
    ) -> Candidate:
        """The route to fly among ``found``.

        Each is routed, and its time guessed with a spur to each gap it leaves (:meth:`_guess`).
        Closing the gaps is the costly part: it is done for the :data:`CLOSED` best guesses, and
        the quickest of those (then the shortest, :func:`chosen`) is flown."""
        for c in found:
            self.route(spec, c)
        if filler is not None:
            # A guess is never below the route's time before its gaps: an angle already slower
            # than CLOSED guesses made cannot be among the closed, and its gap search (a U's
            # third angle: 6 ms) is not made (quickest routes first, so the guesses are low).
            guessed: list[float] = []
            for c in sorted(found, key=lambda c: c.time_s):
                if len(guessed) >= CLOSED and c.time_s > sorted(guessed)[CLOSED - 1]:
                    c.guess = math.inf
                    continue
                self._guess(c, filler)
                guessed.append(c.guess)
        closed: list[Candidate] = []
        for c in sorted(found, key=lambda c: c.guess)[:CLOSED]:  # stable: the shortlist's order
            # A guess is no bound (strokes often close gaps for less than a spur each), so the
            # likeliest few are closed whatever their guesses; but closing only adds to a
            # route, so one that can no longer be chosen over those closed is not closed, and
            # closing stops once it cannot (:func:`beaten`).
            done = [(d.time_s, d.length_m) for d in closed]
            if beaten(c.time_s, c.length_m, done):
                continue
            if filler is not None:
                self.close_gaps(c, filler, self._beaten(c, done) if done else None)
                self._cost(spec, c)
            closed.append(c)
        return chosen(closed)

    def filler(self, spec: AreaSpec, area: Polygon, spacing: float) -> GapFiller | None:
        """The gap filler for ``spec``'s coverage target (None when gaps are left open)."""
        if not self.fill_gaps:
            return None
        return GapFiller(
            spacing / 2.0,
            GAP_TOLERANCE * spacing,
            PathBuilder(spacing),
            leave_m2=(1.0 - spec.coverage_target_pct / 100.0) * area.area,
            sliver_m=SLIVER_SPACINGS * spacing,
            detours=self.detours,
        )

    def _beaten(self, c: Candidate, closed: list[tuple[float, float]]) -> Over:
        """Whether ``c``'s points can no longer be chosen over ``closed`` (:func:`beaten`)."""
        return lambda points: beaten(*self.timing.timed(points, c.hold_s), closed)

    def close_gaps(self, c: Candidate, filler: GapFiller, over: Over | None = None) -> None:
        """Cover what ``c`` leaves, up to the coverage target (stage 6): on small fields by
        detours and spikes off the route as it is, else spurs (:meth:`GapFiller.fill`); on
        larger ones the solver first weaves a stroke across each gap into the route (200 m
        shorter than spurs on a 9 ha field). Below a 100 % target small fields try the strokes
        too and fly the quicker (then the shorter, :func:`quicker`): a star at 97.5 % flies
        459 m so, 476 m by detours. At 100 % they no longer do: since detours may spike off a
        leg the strokes never won there (a star's, an arrowhead's, a dog-leg's routes were
        1-12 % longer), and the second solve and fill were a quarter of their planning."""
        routed = c.routed
        assert routed is not None
        # Detours on small fields only: on the bench's 2.9 ha farm, 9 ha field and square
        # kilometre they found (next to) nothing the strokes or spurs did not, in up to seven
        # times the planning time.
        squares = c.sweep_area.area / c.builder.spacing_m**2
        small = len(routed.passes) <= STROKES_UP_TO and squares <= DETOUR_SQUARES
        filler = replace(filler, builder=c.builder, detours=filler.detours and small)
        weave = routed.solved and len(routed.passes) <= STROKES_UP_TO
        weave &= not small or filler.leave_m2 > 0
        options: list[tuple[Routed, list[RoutePoint], list[Polygon]]] = []
        if small or not weave:
            points, left = filler.fill(
                c.points, c.sweep_area, routed.transits, over=over, first=c.gaps
            )
            options.append((routed, points, left))
        if weave:
            strokes, kept, budget = filler.strokes(c.points, c.sweep_area, c.gaps)
            woven, built, first = routed, c.points, c.gaps
            if strokes:
                woven = self.orderer.reorder(
                    routed.passes, list(strokes), c.start, c.sweep_area, routed
                )
                built, first = c.builder.build(woven.passes, woven.transits), None
            if strokes or not options:
                points, left = filler.fill(
                    built, c.sweep_area, woven.transits, kept, budget, over, first
                )
                options.append((woven, points, left))
        timed = [(self.timing.of(p, c.hold_s), route_length(p)) for _, p, _ in options]
        # An option ``over`` stopped part-way cannot be chosen: no rival to a finished one.
        live = [over is None or len(options) == 1 or not over(p) for _, p, _ in options]
        c.routed, c.points, c.left = options[quicker_live(timed, live)]

    def _guess(self, c: Candidate, filler: GapFiller) -> None:
        """``c``'s time with a spur to each gap, across it and back: what ranks the angles."""
        c.gaps = filler.gaps(c.points, c.sweep_area)
        kept = filler.slivers(c.points, c.gaps, filler.leave_m2) if filler.leave_m2 > 0 else []
        gaps = [g for g in c.gaps if not any(g is k for k in kept)]  # the target lets these be
        if not gaps:
            return
        xy = route_xy(c.points)
        path = LineString(xy) if len(xy) > 1 else Point(xy[0])
        near = shapely.distance(path, shapely.points([g.near for g in gaps]))
        far = shapely.distance(path, shapely.points([g.far for g in gaps]))
        across = np.array([math.dist(g.near, g.far) for g in gaps])
        # Out, across and back: three turns; a stopping survey holds every spacing across.
        metres = float((near + across + far).sum()) + 3 * len(gaps) * self.timing.turn_m
        holds = 0.0 if c.builder.fly_through else float(np.ceil(across / c.builder.spacing_m).sum())
        c.guess = c.time_s + metres / self.timing.speed_mps + holds * c.hold_s

    def _cost(self, spec: AreaSpec, c: Candidate) -> None:
        c.length_m = route_length(c.points)
        c.time_s = self.timing.of(c.points, c.hold_s)


def shortlist_size(area: Polygon, spacing_m: float) -> int:
    """How many angles to plan to the end for an area (see :data:`SHORTLIST`): one for a traced
    outline (over :data:`TRACED_VERTICES`), as before issue 30 — closing the gaps of a 2000-vertex
    comb or gear at a second angle took seconds, past issue 11's budget."""
    if vertices(area) > TRACED_VERTICES:
        return 1
    squares = area.area / (spacing_m * spacing_m)
    return next((size for most, size in SHORTLIST if squares <= most), 1)


def _hold_s(spec: AreaSpec) -> float:
    if spec.action == Action.TAKEPIC:
        return 0.0 if spec.fly_through else PICTURE_S
    return spec.hold_s if spec.action == Action.READ_SENSORS else 0.0


def _rings(projection: LocalProjection, shape: Polygon) -> list[tuple[float, float]]:
    """A gap's outline as [lat, lon] pairs (closed)."""
    out = []
    for x, y in shape.exterior.coords:
        p = projection.to_lla(x, y)
        out.append((p.lat, p.lon))
    return out


def _unrotate(points: list[RoutePoint], angle: float) -> tuple[list[RoutePoint], np.ndarray]:
    """The route's points back in the local plane, and their coordinates as an array: one
    rotation of them all (:func:`from_sweep_xy` point by point was a tenth of the planning)."""
    a = math.radians(90.0 - angle)
    c, s = math.cos(a), math.sin(a)
    x, y = route_xy(points).T
    xy = np.column_stack((x * c - y * s, x * s + y * c))
    local = [
        RoutePoint(u, v, p.kind, p.trigger_m, p.photos)
        for (u, v), p in zip(xy.tolist(), points, strict=True)
    ]
    return local, xy


def plan_area(spec: AreaSpec) -> CoveragePlan:
    """Plan ``spec`` with the default pipeline."""
    return CoveragePipeline().plan(spec)
