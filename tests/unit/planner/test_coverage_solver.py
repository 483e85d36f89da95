"""The swaths' order inside a field (issue 30): transits and the route solver.

On the bench's fields (tests/support/f2c_fields.py), swept at a fixed angle: a transit between two
swath ends is the shortest way inside the field plus a cost per bend, and the solver's order of
the swaths is never costlier than flying the cells one after another (the field with a pond is
cheaper), the same every time.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from shapely.geometry import LineString, Polygon

from dronefleet.ground.planner.coverage.decompose import BoustrophedonDecomposer
from dronefleet.ground.planner.coverage.route import BoustrophedonOrderer
from dronefleet.ground.planner.coverage.router import InAreaRouter
from dronefleet.ground.planner.coverage.solver import RouteSolver, route_cost
from dronefleet.ground.planner.coverage.swaths import SwathGenerator, to_sweep
from dronefleet.ground.planner.coverage.transits import BEND_M, TransitTable
from support.f2c_fields import FIELDS, SPACING


def swath_table(name: str, angle: float):
    f = FIELDS[name]
    area = to_sweep(Polygon(f["outline_m"], f["holes_m"]), angle)
    cells = BoustrophedonDecomposer().cells(SwathGenerator(SPACING).lines(area))
    passes = BoustrophedonOrderer().order(cells, (0.0, 0.0))
    ends = np.array(
        [[(min(p.x_from, p.x_to), p.y), (max(p.x_from, p.x_to), p.y)] for p in passes]
    ).reshape(-1, 2)
    return area, passes, TransitTable(area, ends)


def test_transits_are_the_shortest_way_inside_the_field_with_a_cost_per_bend():
    area, _, table = swath_table("field with a pond", 90.0)
    router = InAreaRouter(area)
    n = len(table.points)
    for i, j in itertools.combinations(range(n), 2):
        path = table.path(i, j)
        assert area.buffer(1e-3).covers(LineString(path)), (i, j)
        bends = len(path) - 2
        length = LineString(path).length
        assert table.cost[i, j] == pytest.approx(length + BEND_M * bends, abs=1e-6)
        shortest = LineString(router.path(*(tuple(table.points[k]) for k in (i, j)))).length
        assert length <= shortest + BEND_M * bends + 1e-6  # never a detour beyond its bends
    assert table.exact.all()


def test_the_solver_never_returns_a_route_costlier_than_the_cell_by_cell_one():
    for name, angle in [
        ("field with a pond", 90.0),
        ("U-shaped", 90.0),
        ("farm with three holes", 0.0),
    ]:
        _, passes, table = swath_table(name, angle)
        initial = [(i, p.x_from > p.x_to) for i, p in enumerate(passes)]
        solved = RouteSolver().solve(table.cost, initial)
        assert sorted(s for s, _ in solved) == list(range(len(passes)))  # each swath once
        assert route_cost(table.cost, solved) <= route_cost(table.cost, initial) + 1e-9
        assert RouteSolver().solve(table.cost, initial) == solved  # deterministic


def test_a_field_with_a_pond_is_not_flown_cell_after_cell():
    # The cells either side of the pond share their turns; cell by cell pays a crossing.
    _, passes, table = swath_table("field with a pond", 90.0)
    initial = [(i, p.x_from > p.x_to) for i, p in enumerate(passes)]
    solved = RouteSolver().solve(table.cost, initial)
    assert route_cost(table.cost, solved) < route_cost(table.cost, initial) - SPACING
