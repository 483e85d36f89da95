"""An error raised in the planning worker's process comes back as itself, and the worker plans on
(issue 26: a separation conflict raised there could not be unpickled, the pool broke for good,
and the ground could choose no replacement any more)."""

from __future__ import annotations

import pytest

from dronefleet.geo.types import LLA
from dronefleet.ground.planner.separation import Conflict, SeparationConflict
from dronefleet.ground.planner.worker import PlanningWorker


def conflicting(tried: str) -> None:
    conflict = Conflict("QUAD_A", "QUAD_B", 12.0, LLA(40.63, -8.659, 20.0), 1.5, 0.5)
    raise SeparationConflict(conflict, tried)


def square(x: int) -> int:
    return x * x


async def test_a_conflict_raised_in_the_worker_comes_back_whole_and_the_worker_plans_on():
    worker = PlanningWorker(processes=1, budget_s=60)
    try:
        with pytest.raises(SeparationConflict) as raised:
            await worker.run(conflicting, "later starts")
        assert raised.value.conflict.drone_b == "QUAD_B"
        assert "later starts" in str(raised.value)
        assert await worker.run(square, 7) == 49
    finally:
        worker.close()
