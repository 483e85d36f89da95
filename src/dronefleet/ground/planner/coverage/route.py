"""Stage 4 of the coverage pipeline: order the swaths into a boustrophedon route.

Cells are visited greedily, nearest entry first (a cell can be entered at either end of its first
or its last swath); inside a cell the swaths alternate direction, the seed's back-and-forth path
(Figure 5.11). The route starts at the entry nearest to ``start`` (default: the polygon's first
vertex, so the person drawing the area decides where the work begins).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from dronefleet.ground.planner.coverage.decompose import Cell

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
        todo = list(cells)
        here = start
        route: list[Pass] = []
        while todo:
            best: tuple[float, int, bool, bool] | None = None
            for k, cell in enumerate(todo):
                for reverse in (False, True):
                    _, y, x0, x1 = cell.segments[-1] if reverse else cell.segments[0]
                    for left_first in (True, False):
                        d = math.dist(here, (x0 if left_first else x1, y))
                        if best is None or d < best[0] - 1e-9:
                            best = (d, k, reverse, left_first)
            assert best is not None
            _, k, reverse, left_first = best
            passes = _sweep(todo.pop(k), reverse, left_first)
            route.extend(passes)
            here = passes[-1].end
        return route
