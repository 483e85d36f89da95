"""A drone that loses its broker mid-mission does what its operator chose (issue 13).

ArduPilot's GCS failsafe chooses what the vehicle does when the ground falls silent; here
``dronefleet drone --link-loss`` does for the broker link: fly on (the default, shown by
test_broker_outage.py), hold, or return home. A real Mosquitto is killed mid-mission for 30
vehicle seconds (the timeout is 3); a real ``dronefleet drone`` process flies.
"""

from __future__ import annotations

import asyncio
import math

import orjson
import pytest

from dronefleet.messaging.client import BrokerClient
from support.brokers import Mosquitto
from support.processes import dronefleet, process

pytestmark = pytest.mark.integration

SPEEDUP = 10
OUTAGE_WALL_S = 3.0
HOME = (40.63, -8.659)
HOME_ALT_M = 10.0
M_PER_DEG = 111_320.0


def mission() -> dict:
    steps: list[dict] = [{"command": "arm"}, {"command": "takeoff", "value": 10}]
    for i in range(12):
        steps += [
            {"command": "navigate", "lat": HOME[0] + 0.00012 * (i + 1), "lon": HOME[1],
             "altitude_delta": 10},
            {"command": "wait_for_flight"},
        ]  # fmt: skip
    return {"mission_id": "link-1", "steps": [*steps, {"command": "land"}]}


@pytest.mark.parametrize("action", ["hold", "rtl"])
async def test_a_lost_link_stops_the_mission_and_the_drone_holds_or_goes_home(action, tmp_path):
    reports: list[dict] = []
    telemetry: list[dict] = []

    async def collect(_topic: str, payload: bytes) -> None:
        reports.append(orjson.loads(payload))

    async def sample(_topic: str, payload: bytes) -> None:
        telemetry.append(orjson.loads(payload))

    def steps_done() -> int:  # distinct steps: a report asked for again comes twice
        return len({r["step_index"] for r in reports if r.get("event") == "step"})

    broker = Mosquitto(tmp_path, persistent=True)
    url = broker.start().full()
    drone = dronefleet("drone", "--id", "QUAD_1", "--broker", url, "--fc", "sim",
                       "--home", f"{HOME[0]},{HOME[1]},{HOME_ALT_M:g}", "--speedup", str(SPEEDUP),
                       "--link-loss", action, "--link-loss-timeout", "3")  # fmt: skip
    try:
        with process(drone, tmp_path / "drone.log"):
            ground = BrokerClient(url, "link-ground", persistent_session=True)
            await ground.subscribe("QUAD_1/mission/out", collect, qos=1)
            await ground.subscribe("QUAD_1/telemetry/out", sample)
            await ground.start(timeout_s=20)
            async with asyncio.timeout(60):  # the drone is up: it publishes only once subscribed
                while not telemetry:
                    await asyncio.sleep(0.05)
            await ground.publish("QUAD_1/mission/in", mission(), qos=1)
            async with asyncio.timeout(60):
                while steps_done() < 6:  # past its second waypoint
                    await asyncio.sleep(0.05)
            broker.stop(kill=True)
            await asyncio.sleep(OUTAGE_WALL_S)
            broker.start()
            # A killed broker kept no session: what the drone sent before the ground was back
            # is asked for again, as the planner does after a reconnect (planner/reconcile.py).
            ask = {"action": "report", "mission_id": "link-1", "request_id": "report-1"}
            async with asyncio.timeout(60):
                while not any(r.get("event") == "stopped" for r in reports):
                    await ground.wait_connected(timeout_s=10)
                    await ground.publish("QUAD_1/mission/in", ask, qos=1)
                    await asyncio.sleep(1.0)
            await asyncio.sleep(3.0)  # 30 vehicle seconds more
            await ground.stop()
    finally:
        broker.stop()

    stopped = next(r for r in reports if r.get("event") == "stopped")
    assert "link to the ground lost" in stopped["error"] and action in stopped["error"]
    assert not any(r.get("event") == "completed" for r in reports)
    assert steps_done() < len(mission()["steps"])  # the rest was never flown
    last = telemetry[-1]["fields"]
    height_m = last["alt_m"] - HOME_ALT_M
    north_m = (last["lat"] - HOME[0]) * M_PER_DEG
    east_m = (last["lon"] - HOME[1]) * M_PER_DEG * math.cos(math.radians(HOME[0]))
    if action == "rtl":  # home, and down
        assert math.hypot(north_m, east_m) < 3.0 and height_m < 0.5, last
    else:  # still up, where the mission was left (a few waypoints out, not home)
        assert height_m > 5.0 and north_m > 20.0, last
