"""A mission paused when someone else takes the vehicle; resumed or stopped from the ground (issue
10).

In-process simulated vehicles: an RC pilot's mode switch is the vehicle's own hold or land, called
beside the drone software; the autopilot's battery failsafe lands by itself. Each pauses the
mission within one telemetry period; a resume flies the steps not done; a stop ends it.
"""

from __future__ import annotations

import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.drone.takeover import SOMEONE_ELSE
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.simfleet import SimFleet
from support.drones import Operator, until_mid_leg

pytestmark = pytest.mark.integration
HOME = LLA(40.63, -8.659, 10.0)


def line(waypoints: int, spacing_m: float = 40.0) -> list[dict]:
    steps: list[dict] = [{"command": "arm"}, {"command": "takeoff", "value": 10}]
    for i in range(waypoints):
        wp = ned_to_lla(NED(spacing_m * (i + 1), 0), HOME)
        steps += [
            {"command": "navigate", "lat": wp.lat, "lon": wp.lon, "altitude_delta": 10},
            {"command": "wait_for_flight"},
        ]
    return [*steps, {"command": "land"}, {"command": "wait_for_flight"}]


def events(op: Operator, mission_id: str, kind: str) -> list[dict]:
    return [p for p in op.progress(mission_id) if p["event"] == kind]


async def test_an_rc_pilots_hold_pauses_the_mission_and_a_resume_finishes_it(embedded_broker):
    steps = line(4)
    async with SimFleet(speedup=20) as fleet, Operator(embedded_broker) as op:
        await fleet.add_drone(DroneConfig(drone_id="QUAD_T"), embedded_broker, home=HOME)
        vehicle = fleet.world.vehicles["QUAD_T"]
        await op.send_mission("QUAD_T", mission_id="t1", steps=steps)
        await op.wait_for(lambda: len(events(op, "t1", "step")) >= 4, timeout_s=60)
        await until_mid_leg(vehicle)
        taken_at = fleet.clock.now()
        vehicle.hold()  # the pilot's mode switch: not the drone software's choice
        (paused,) = await op.wait_for(lambda: events(op, "t1", "paused"), timeout_s=20)
        assert -0.01 <= paused["vehicle_time_s"] - taken_at <= 1.0, paused
        assert paused["result"]["by"] == SOMEONE_ELSE and paused["result"]["mode"] == "HOLD"
        assert "taken over" in paused["error"]
        steps_then = len(events(op, "t1", "step"))
        await fleet.clock.sleep(3.0)  # braking from cruise speed into the hold
        where = vehicle.position_ned
        await fleet.clock.sleep(12.0)  # the vehicle is the pilot's: nothing flies it on
        assert len(events(op, "t1", "step")) == steps_then
        assert (vehicle.position_ned - where).horizontal_m < 2.0
        await op.send_mission("QUAD_T", mission_id="t1", action="resume", request_id="r-1")
        (resumed,) = await op.wait_for(lambda: events(op, "t1", "resumed"), timeout_s=20)
        assert resumed["request_id"] == "r-1" and resumed["step_index"] == paused["step_index"]
        await op.wait_for(lambda: events(op, "t1", "completed"), timeout_s=120)
        done = sorted({p["step_index"] for p in events(op, "t1", "step")})
        assert done == list(range(len(steps)))  # every step, none skipped
        assert not events(op, "t1", "failed")
        assert not vehicle.in_air


async def test_a_vehicle_landed_by_someone_else_stays_paused_until_stopped(embedded_broker):
    async with SimFleet(speedup=20) as fleet, Operator(embedded_broker) as op:
        await fleet.add_drone(DroneConfig(drone_id="QUAD_L"), embedded_broker, home=HOME)
        vehicle = fleet.world.vehicles["QUAD_L"]
        await op.send_mission("QUAD_L", mission_id="t2", steps=line(4))
        await op.wait_for(lambda: len(events(op, "t2", "step")) >= 4, timeout_s=60)
        await until_mid_leg(vehicle)
        vehicle.land()
        await op.wait_for(lambda: events(op, "t2", "paused"), timeout_s=20)
        while vehicle.armed:
            await fleet.clock.sleep(1.0)
        await op.send_mission("QUAD_L", mission_id="t2", action="resume")
        refused = await op.wait_for(lambda: events(op, "t2", "paused")[1:], timeout_s=20)
        assert refused[0]["ok"] is False and "on the ground" in refused[0]["error"]
        assert not events(op, "t2", "resumed") and not vehicle.armed
        await op.send_mission("QUAD_L", mission_id="t2", action="stop")
        (stopped,) = await op.wait_for(lambda: events(op, "t2", "stopped"), timeout_s=20)
        assert "while paused" in stopped["error"]
        assert not events(op, "t2", "failed") and not events(op, "t2", "completed")


async def test_the_autopilots_battery_failsafe_pauses_the_mission_and_says_so(embedded_broker):
    async with SimFleet(speedup=50) as fleet, Operator(embedded_broker) as op:
        await fleet.add_drone(
            # The drone's own battery levels below the autopilot's 5 % failsafe: it acts first.
            DroneConfig(
                drone_id="QUAD_B",
                battery_critical_pct=1.0,
                battery_rtl_pct=1.0,
                battery_land_pct=0.5,
            ),
            embedded_broker,
            home=HOME,
            battery_pct=8.0,
        )
        await op.send_mission("QUAD_B", mission_id="t3", steps=line(30, 100.0))
        (paused,) = await op.wait_for(lambda: events(op, "t3", "paused"), timeout_s=120)
        assert paused["result"]["by"] == "the autopilot", paused
        assert "battery failsafe" in paused["result"]["reason"]
        assert paused["result"]["mode"] == "LAND"
        assert not events(op, "t3", "failed")


async def test_a_pause_asked_on_the_ground_holds_and_a_resume_takes_off(embedded_broker):
    steps = line(2)
    async with SimFleet(speedup=20) as fleet, Operator(embedded_broker) as op:
        await fleet.add_drone(DroneConfig(drone_id="QUAD_P"), embedded_broker, home=HOME)
        vehicle = fleet.world.vehicles["QUAD_P"]
        await op.send_mission("QUAD_P", mission_id="t4", steps=steps)
        await op.wait_for(lambda: events(op, "t4", "accepted"), timeout_s=20)
        await op.send_mission("QUAD_P", mission_id="t4", action="pause")
        (paused,) = await op.wait_for(lambda: events(op, "t4", "paused"), timeout_s=20)
        assert paused["error"] == "paused by the operator: holding", paused
        await fleet.clock.sleep(10.0)
        assert not vehicle.in_air and not events(op, "t4", "completed")
        await op.send_mission("QUAD_P", mission_id="t4", action="resume")
        await op.wait_for(lambda: events(op, "t4", "completed"), timeout_s=120)
        done = sorted({p["step_index"] for p in events(op, "t4", "step")})
        assert done == list(range(len(steps))) and not events(op, "t4", "failed")
