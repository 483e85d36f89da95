"""``bench/sim_scale.py --processes K`` end to end at a tiny size (issue 27, item 5).

Two worker processes of three simulated drones each, on the embedded NATS broker with a user and
password per drone (as the demo makes them), the ground services in a process of their own,
paced at 4x for 12 vehicle seconds: every drone is listed by the ground's Drone Identifier and
heard, none declared lost, each worker carried its share and its vehicle time moved, the ground
received telemetry, and the report prints a line per worker.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.integration

BENCH = Path(__file__).resolve().parents[2] / "bench"


@pytest.fixture
def sim_scale(monkeypatch):
    monkeypatch.syspath_prepend(str(BENCH))  # the bench's own imports (mqtt_load), and spawn's
    import sim_scale

    yield sim_scale
    sys.modules.pop("sim_scale", None)


async def test_drones_over_two_workers_beside_the_ground(sim_scale, monkeypatch):
    monkeypatch.setattr(sim_scale, "STARTUP_LIMIT_S", 180.0)  # a hang fails in minutes, not 15
    r = await sim_scale.measure_spread(6, 2, vehicle_s=12.0, speedup=4.0, warmup_s=0.5)

    assert r["ground"]["listed"] == 6
    assert r["heard"] == 6
    assert r["lost"] == 0
    assert r["ground"]["lost_now"] == 0
    assert [w["drones"] for w in r["workers"]] == [3, 3]
    assert all(w["vehicle_s"] > 0 for w in r["workers"])
    assert r["ground"]["telemetry_per_wall_s"] > 0
    report = sim_scale.spread_lines(r)
    assert "worker 0: 3 drones" in report
    assert "worker 1: 3 drones" in report
