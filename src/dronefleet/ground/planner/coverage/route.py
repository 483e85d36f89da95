"""Stage 4 of the coverage pipeline: order the swaths into a route.

:class:`BoustrophedonOrderer` visits cells greedily, nearest entry first (a cell can be entered at
either end of its first or its last swath); inside a cell the swaths alternate direction, the
seed's back-and-forth path (Figure 5.11). :class:`WholeFieldOrderer` starts from that route and
lets the solver (:mod:`.solver`) reorder the swaths over the whole field, costing transits inside
the area (:mod:`.transits`). The route starts at the end nearest to ``start`` (default: the
polygon's first vertex, so the person drawing the area decides where the work begins).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from shapely.geometry import Polygon

from dronefleet.ground.planner.coverage.decompose import Cell
from dronefleet.ground.planner.coverage.router import InAreaRouter
from dronefleet.ground.planner.coverage.solver import Order, RouteSolver, ends_of, route_cost
from dronefleet.ground.planner.coverage.transits import BEND_M, TransitTable, affordable

XY = tuple[float, float]


@dataclass(frozen=True)
class Pass:
    """One swath flown from (x_from, y) to (x_to, y) in the sweep frame."""

    line: int
    y: float
    x_from: float
    x_to: float

    @property
    def start(self) -> XY:
        return self.x_from, self.y

    @property
    def end(self) -> XY:
        return self.x_to, self.y

    @property
    def length_m(self) -> float:
        return abs(self.x_to - self.x_from)


def _sweep(cell: Cell, reverse: bool, left_first: bool) -> list[Pass]:
    segs = cell.segments[::-1] if reverse else cell.segments
    out = []
    left = left_first
    for line, y, x0, x1 in segs:
        out.append(Pass(line, y, x0, x1) if left else Pass(line, y, x1, x0))
        left = not left
    return out


@dataclass(frozen=True)
class BoustrophedonOrderer:
    """Cells in greedy nearest-entry order, back and forth inside each."""

    def order(self, cells: list[Cell], start: XY) -> list[Pass]:
        # Entries of every cell: (first swath, last swath) x (left end, right end), in the
        # order they are tried; the nearest one left wins, the first of those within 1e-9 m of
        # it on a tie. Measured all at once: 669 cells (a 2000-vertex gear) were 900,000
        # distances in a Python loop, a seventh of its planning.
        entries = np.array(
            [
                [(seg[2], seg[1]), (seg[3], seg[1])]
                for cell in cells
                for seg in (cell.segments[0], cell.segments[-1])
            ],
            dtype=float,
        ).reshape(len(cells) * 4, 2)
        left = np.ones(len(cells) * 4, dtype=bool)
        here = start
        route: list[Pass] = []
        for _ in cells:
            d = np.where(left, np.hypot(entries[:, 0] - here[0], entries[:, 1] - here[1]), np.inf)
            pick = int(np.argmax(d <= d.min() + 1e-9))
            k, reverse, left_first = pick // 4, bool(pick % 4 // 2), pick % 2 == 0
            left[4 * k : 4 * k + 4] = False
            passes = _sweep(cells[k], reverse, left_first)
            route.extend(passes)
            here = passes[-1].end
        return route


class Transits(Protocol):
    """Where the drone flies between two points of the area (router.py, transits.py)."""

    def path(self, a: XY, b: XY) -> list[XY]: ...


@dataclass(frozen=True)
class Routed:
    """Swaths in flying order, and the way between any two points (``transits.path``)."""

    passes: list[Flown]
    transits: Transits
    solved: bool = False  # ordered by the solver (else cell by cell)


class TableTransits:
    """Transits between swath ends from the solver's table; other points by the router."""

    def __init__(self, table: TransitTable, router: InAreaRouter) -> None:
        self.table, self.router = table, router
        self._index = {(float(x), float(y)): i for i, (x, y) in enumerate(table.points.tolist())}

    def path(self, a: XY, b: XY) -> list[XY]:
        i, j = self._index.get(a), self._index.get(b)
        if i is None or j is None:
            return self.router.path(a, b)
        return self.table.path(i, j)


@dataclass(frozen=True)
class Stroke:
    """A short pass that is not a swath: across a gap the swaths leave (:mod:`.gaps`)."""

    start: XY
    end: XY

    @property
    def length_m(self) -> float:
        return float(np.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1]))


Flown = Pass | Stroke


def _ends(p: Flown) -> tuple[XY, XY]:
    """The pass's ends in a fixed order (swaths: west end first), whichever way it is flown."""
    if isinstance(p, Pass):
        return (min(p.x_from, p.x_to), p.y), (max(p.x_from, p.x_to), p.y)
    return min(p.start, p.end), max(p.start, p.end)


def _flown(p: Flown, reverse: bool) -> Flown:
    (x0, y0), (x1, y1) = _ends(p)
    if isinstance(p, Pass):
        return Pass(p.line, p.y, x1, x0) if reverse else Pass(p.line, p.y, x0, x1)
    return Stroke((x1, y1), (x0, y0)) if reverse else Stroke((x0, y0), (x1, y1))


@dataclass(frozen=True)
class WholeFieldOrderer:
    """Swaths ordered by the solver over the whole field; cell by cell where a transit table
    would cost more than it saves (:func:`~.transits.affordable`: traced outlines)."""

    cells: BoustrophedonOrderer = field(default_factory=BoustrophedonOrderer)
    solver: RouteSolver = field(default_factory=RouteSolver)
    bend_m: float = BEND_M
    rounds: int = 8  # solutions tried before the transits they use are all exact

    def order(self, cells: list[Cell], start: XY, area: Polygon) -> Routed:
        first: list[Flown] = list(self.cells.order(cells, start))
        return self.reorder(first, [], start, area)

    def reorder(
        self,
        passes: list[Flown],
        extra: list[Flown],
        start: XY,
        area: Polygon,
        base: Routed | None = None,
    ) -> Routed:
        """``passes`` (in a flying order) and ``extra`` ones ordered by the solver; ``base``, a
        route of the same area whose router and corners are reused."""
        old = base.transits if base is not None else None
        router = old.router if isinstance(old, TableTransits) else InAreaRouter(area)
        flown = [*passes, *extra]
        if len(flown) < 3 or not affordable(area, 2 * len(flown)):
            return Routed([*passes, *extra], router)
        ends = np.array([_ends(p) for p in flown], dtype=float).reshape(-1, 2)
        like = old.table if isinstance(old, TableTransits) else None
        table = TransitTable(area, ends, self.bend_m, like)
        initial: Order = [(i, _ends(p)[0] != p.start) for i, p in enumerate(passes)]
        for k in range(len(passes), len(flown)):
            initial = _insert(table.cost, initial, k)
        near = np.hypot(ends[:, 0] - start[0], ends[:, 1] - start[1])
        order = self._solve(table, initial, int(np.argmin(near)))
        # An open route costs the same both ways: begin at the end nearer ``start``.
        head = 2 * order[0][0] + int(order[0][1])
        tail = 2 * order[-1][0] + 1 - int(order[-1][1])
        if near[tail] < near[head] - 1e-9:
            order = [(s, not r) for s, r in reversed(order)]
        out = [_flown(flown[s], rev) for s, rev in order]
        return Routed(out, TableTransits(table, router), solved=True)

    def _solve(self, table: TransitTable, initial: Order, start_end: int) -> Order:
        """Solve on the table's costs, making exact the transits each solution uses, until a
        solution uses only exact ones (a lower bound only ever rises, so few rounds do); never
        worse than ``initial``."""
        entry, exit_ = ends_of(initial)
        table.verify(exit_[:-1], entry[1:])
        order = self.solver.solve(table.cost, initial, start_end)
        for _ in range(self.rounds):
            entry, exit_ = ends_of(order)
            unsure = ~table.exact[exit_[:-1], entry[1:]]
            if not unsure.any():
                break
            # Every pair of the ends concerned: else the next solution finds the next guess
            # through the same pond from them, a round each.
            table.verify_rows(np.concatenate([exit_[:-1][unsure], entry[1:][unsure]]))
            order = self.solver.improve(table.cost, order)
        if route_cost(table.cost, order) > route_cost(table.cost, initial):
            return initial
        return order


def _insert(cost: np.ndarray, order: Order, k: int) -> Order:
    """``order`` with swath ``k`` where it adds least, either way round."""
    entry, exit_ = ends_of(order)
    a, b = 2 * k, 2 * k + 1
    # Before the first, between each pair, after the last.
    before = np.array([cost[b, entry[0]], cost[a, entry[0]]])
    between = np.stack(
        [
            cost[exit_[:-1], a] + cost[b, entry[1:]] - cost[exit_[:-1], entry[1:]],
            cost[exit_[:-1], b] + cost[a, entry[1:]] - cost[exit_[:-1], entry[1:]],
        ],
        axis=1,
    )
    after = np.array([cost[exit_[-1], a], cost[exit_[-1], b]])
    options = np.vstack([before[None, :], between, after[None, :]])
    at, rev = divmod(int(np.argmin(options)), 2)
    return [*order[:at], (k, bool(rev)), *order[at:]]
