"""Issue 29, item 9: a direct move is answered when accepted and reported done only when the
drone is there (drone/command_watch.py); the flight-mode command (HOLD, GUIDED, LAND, RTL)."""

from __future__ import annotations

import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.simfleet import SimFleet
from support.drones import Operator

pytestmark = pytest.mark.integration
HOME = LLA(40.63, -8.659, 10.0)
DRONE = "QUAD_CMD"


def ends(op: Operator, request_id: str) -> list[dict]:
    return [
        m
        for m in op.received["control/out"]
        if m.get("request_id") == request_id and m.get("done") is True
    ]


async def end_of(op: Operator, answer: dict, timeout_s: float = 60.0) -> dict:
    (end,) = await op.wait_for(lambda: ends(op, answer["request_id"]), timeout_s, "control/out")
    return end


async def test_a_move_is_done_when_the_drone_is_there_not_when_it_accepts(embedded_broker):
    async with SimFleet(speedup=20) as fleet, Operator(embedded_broker) as op:
        await fleet.add_drone(DroneConfig(drone_id=DRONE), embedded_broker, home=HOME)
        vehicle = fleet.world.vehicles[DRONE]
        armed = await op.command(DRONE, command="arm")
        assert armed["ok"] is True and armed["done"] is True  # arming returns once armed

        takeoff = await op.command(DRONE, command="takeoff", value=10)
        assert takeoff["ok"] is True and takeoff["done"] is False
        assert takeoff["result"]["target"]["above_home_m"] == pytest.approx(10)
        assert takeoff["result"]["target"]["alt_m"] == pytest.approx(HOME.alt_m + 10)
        assert ends(op, takeoff["request_id"]) == []  # not yet: it has only started climbing
        end = await end_of(op, takeoff)
        assert (end["ok"], end["outcome"], end["command"]) == (True, "reached", "takeoff")
        height_m = vehicle.position_ned.d * -1
        assert 8.0 < height_m < 12.0, height_m  # it is up when "done" comes
        assert end["result"]["position"]["above_home_m"] == pytest.approx(10, abs=2)

        # South: a negative changeN; done where the drone reports it reached the goal.
        south = await op.command(DRONE, command="changeN", value=-20)
        assert south["done"] is False
        end = await end_of(op, south)
        assert end["outcome"] == "reached"
        assert vehicle.position_ned.n == pytest.approx(-20, abs=2.5)

        # A long goto stopped half way by HOLD: the goto is superseded, the HOLD holds.
        far = ned_to_lla(NED(200, 0), HOME)
        goto = await op.command(
            DRONE, command="navigate", lat=far.lat, lon=far.lon, altitude_delta=10
        )
        await op.wait_for(lambda: vehicle.position_ned.n > 20, 60, "heartbeats/out")
        hold = await op.command(DRONE, command="mode", value="HOLD", sender="alice")
        assert hold["ok"] is True and hold["result"]["mode"] == "HOLD"
        assert (await end_of(op, goto))["outcome"] == "superseded"
        held = await end_of(op, hold)
        assert (held["ok"], held["outcome"]) == (True, "holding")
        assert 20 < vehicle.position_ned.n < 190
        assert vehicle.velocity_ned.horizontal_m < 1.0

        # LAND through the mode selector: done once it is on the ground.
        land = await op.command(DRONE, command="mode", value="LAND")
        end = await end_of(op, land, timeout_s=90)
        assert (end["ok"], end["outcome"]) == (True, "landed")
        assert end["result"]["position"]["above_home_m"] < 0.5

        refused = await op.command(DRONE, command="mode", value="GUIDED")
        assert refused["ok"] is False and "take off first" in refused["error"]
        bad = await op.command(DRONE, command="mode", value="STABILIZE")
        assert bad["ok"] is False and "value" in bad["error"]
