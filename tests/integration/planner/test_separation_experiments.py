"""The four experiments of chapter 5 watched by the separation monitor (issue 14).

Each runs as ``dronefleet experiment`` runs it (scenarios.run: broker, ground services with the
monitor, drones on simulated vehicles, virtual time); the monitor's counts come back with the
result and are printed in its report. No two drones may come within the minima (5 m
horizontally and 3 m vertically at once); none should even be foreseen by the monitor's velocity
extrapolation, which the collaborative extension does not yet achieve (a strict xfail).
"""

from __future__ import annotations

import pytest

from dronefleet.experiments import scenarios
from dronefleet.experiments.report import Result

pytestmark = pytest.mark.integration

EXPERIMENTS = ["panic", "survey", "replacement", "collab"]
#: Experiments with more than one drone in the air at once: the monitor must have compared them.
SEVERAL_UP = {"replacement", "collab"}

_results: dict[str, Result] = {}


async def result_of(name: str) -> Result:
    if name not in _results:
        _results[name] = await scenarios.run(name, strategy="ours")
    return _results[name]


@pytest.mark.virtual_time
@pytest.mark.parametrize("name", EXPERIMENTS)
async def test_no_two_drones_come_within_the_minima_in_the_experiments(name):
    result = await result_of(name)
    figures = result.separation
    assert figures["actual_breaches"] == 0, figures
    assert result.waypoints_reached == result.waypoints_planned
    if name in SEVERAL_UP:
        assert figures["pairs_compared"] > 100, figures
        assert figures["min_distance_m"] is not None and figures["min_distance_m"] > 3.0
        closest = figures["min_horizontal_m"]
        assert closest is None or closest >= 5.0, figures
    assert "separation: " in result.table()  # the report prints the monitor's counts


@pytest.mark.virtual_time
@pytest.mark.parametrize(
    "name",
    [
        *EXPERIMENTS[:3],
        pytest.param(
            "collab",
            marks=pytest.mark.xfail(
                strict=True,
                reason="the collaborative extension sets off one WARNING: a joining drone "
                "takes off under the hovering drone that raised the alarm and passes it 5.03 m "
                "apart (no breach follows; docs/DESIGN.md section 12)",
            ),
        ),
    ],
)
async def test_no_breach_is_even_foreseen_in_the_experiments(name):
    figures = (await result_of(name)).separation
    assert figures["predicted_breaches"] == 0, figures
