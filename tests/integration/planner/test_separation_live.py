"""Two drones sent across each other at the same height (issue 14, separation).

Through the planner, the second mission is checked against the first drone's path and
deconflicted before it is sent (or refused when nothing can keep them apart); flown, the
separation monitor sees no breach. Through direct commands (the operator's /control path, which
no plan checks), the same crossing is flown as sent, and the monitor raises a WARNING a few
seconds ahead and a CRITICAL at the crossing, relayed by the live stream as alarms.
"""

from __future__ import annotations

import asyncio

import pytest

from dronefleet.errors import InvalidInput
from dronefleet.experiments.harness import ORIGIN, Harness
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import NED
from dronefleet.ground.manager.stream import _Listener
from dronefleet.ground.planner import launch
from dronefleet.ground.planner.models import MissionState
from dronefleet.ground.planner.options import MissionOptions
from dronefleet.ground.planner.separation import HORIZONTAL_M, VERTICAL_M
from dronefleet.messaging.commands import parse_control

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]

OPTIONS = MissionOptions(collaboration=False, replacement=False, early_replacement=False)


def to(n: float, e: float, up: float = 10.0) -> dict:
    p = ned_to_lla(NED(n, e), ORIGIN)
    return {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": up}


async def crossing_pair(h: Harness) -> None:
    """QUAD_A hovers 60 m west of the crossing, QUAD_B 60 m south, both at 10 m."""
    await h.add_drone("QUAD_A", NED(0, -60), hovering_m=10)
    await h.add_drone("QUAD_B", NED(-60, 0), hovering_m=10)
    await h.wait_identified(["QUAD_A", "QUAD_B"])
    await h.settle()


async def test_a_crossing_mission_is_deconflicted_and_flown_without_a_breach():
    async with Harness(speedup=20) as h:
        await crossing_pair(h)
        first = launch.MissionSpec(
            name="east", drones=["QUAD_A"], steps=[to(0, 60), {"command": "wait_for_flight"}],
            options=OPTIONS,
        )  # fmt: skip
        second = launch.MissionSpec(
            name="north", drones=["QUAD_B"], steps=[to(60, 0), {"command": "wait_for_flight"}],
            options=OPTIONS,
        )  # fmt: skip
        a = await launch.create(h.planner, first, start=True)
        preview = await launch.preview(h.planner, second)
        (share,) = preview["drones"]
        assert any("separation:" in n and "QUAD_A" in n for n in share["notes"]), share
        b = await launch.create(h.planner, second, start=True)
        leg = b.legs[0]
        raised = [s for s in leg.prefix if s.get("altitude_delta", 0) > 10 + VERTICAL_M]
        held = [s for s in leg.prefix if s["command"] == "sleep"]
        assert raised or held, leg.prefix
        for record in (a, b):
            done = await h.until_ended(record.mission_id, timeout_s=300)
            assert done.state is MissionState.COMPLETED, done.error
        await h.settle(10.0)
        figures = h.separation()
    assert figures["actual_breaches"] == 0, figures
    assert figures["predicted_breaches"] == 0, figures
    assert figures["pairs_compared"] > 100
    assert figures["min_horizontal_m"] is None or figures["min_horizontal_m"] >= HORIZONTAL_M


async def test_a_plan_that_cannot_be_kept_apart_is_refused_naming_both_drones():
    async with Harness(speedup=20) as h:
        await crossing_pair(h)
        # QUAD_B hovers (idle) exactly where QUAD_A's mission would end and hold.
        where = ned_to_lla(NED(-60, 0), ORIGIN)
        spec = launch.MissionSpec(
            name="onto B",
            drones=["QUAD_A"],
            steps=[
                {"command": "navigate", "lat": where.lat, "lon": where.lon, "altitude_delta": 10},
                {"command": "wait_for_flight"},
            ],
            options=OPTIONS.model_copy(update={"end_action": "hold"}),
        )
        with pytest.raises(InvalidInput) as refused:
            await launch.create(h.planner, spec, start=True)
        assert not h.planner.missions  # nothing created
    message = str(refused.value)
    assert "drones QUAD_A and QUAD_B" in message and "s after the start, at 40.6" in message


async def test_direct_commands_across_each_other_raise_warning_then_critical():
    async with Harness(speedup=20) as h:
        await crossing_pair(h)
        assert h.ground is not None and h.ground.hub is not None and h.ground.gateway
        stream = _Listener(None, frozenset({"alarm"}))
        h.ground.hub.listeners.add(stream)
        # The operator's direct commands: no plan, no check; both reach the crossing together.
        await asyncio.gather(
            h.ground.gateway.control("QUAD_A", parse_control(to(0, 60))),
            h.ground.gateway.control("QUAD_B", parse_control(to(60, 0))),
        )
        await h.settle(20.0)
        figures = h.separation()
        alarms = []
        while not stream.queue.empty():
            alarms.append(stream.queue.get_nowait())
    levels = [m["data"]["level"] for m in alarms]
    assert levels[:2] == ["WARNING", "CRITICAL"], alarms
    warning, critical = alarms[0]["data"], alarms[1]["data"]
    assert alarms[0]["drone_id"] == "QUAD_A" and warning["reading"]["other_drone"] == "QUAD_B"
    assert 0.0 < warning["reading"]["in_s"] <= 5.0
    assert "QUAD_A and QUAD_B" in critical["message"]
    assert critical["reading"]["horizontal_m"] < HORIZONTAL_M
    assert critical["reading"]["vertical_m"] < VERTICAL_M
    assert critical["vehicle_time_s"] > warning["vehicle_time_s"]
    assert figures["predicted_breaches"] == 1 and figures["actual_breaches"] == 1, figures
    assert figures["min_horizontal_m"] < 2.0, figures  # they flew right through each other
