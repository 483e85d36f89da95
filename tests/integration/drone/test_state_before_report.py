"""A drone's heartbeat tells a change of its flight state before the report that follows it.

CI (27-28 Nov): right after a mission completed, the ground read its copter as ``armed``: the
report that the landing ended the leg had come before the heartbeat saying the copter was down,
which waited for the next telemetry sample to wake it. Now each mission report is preceded, on
the same link, by a heartbeat when the state or the mode changed since the last one
(drone/status_stream.py, ``tell_state``). A real ``dronefleet drone --fc sim`` process flies
arm, take-off and land; one ground connection subscribed to all its topics sees the order the
broker gave them in.
"""

from __future__ import annotations

import asyncio

import orjson
import pytest

from dronefleet.messaging.client import BrokerClient
from support.brokers import mosquitto
from support.processes import dronefleet, process

pytestmark = pytest.mark.integration

MISSION = {
    "mission_id": "told-1",
    "steps": [{"command": "arm"}, {"command": "takeoff", "value": 5}, {"command": "land"}],
}


async def test_every_report_follows_a_heartbeat_of_the_state_it_reports(tmp_path):
    seen: list[tuple[str, dict]] = []  # (channel, message), in the order they came

    async def keep(topic_name: str, payload: bytes) -> None:
        seen.append((topic_name.split("/")[1], orjson.loads(payload)))

    with mosquitto(tmp_path) as url:
        drone = dronefleet("drone", "--id", "QUAD_1", "--broker", url.full(), "--fc", "sim",
                           "--home", "40.63,-8.659,10", "--speedup", "10")  # fmt: skip
        with process(drone, tmp_path / "drone.log"):
            ground = BrokerClient(url, "told-ground")
            await ground.subscribe("QUAD_1/+/out", keep, qos=1)
            await ground.start(timeout_s=20)
            async with asyncio.timeout(60):  # the drone is up: it publishes once subscribed
                while not any(channel == "heartbeats" for channel, _ in seen):
                    await asyncio.sleep(0.05)
            await ground.publish("QUAD_1/mission/in", MISSION, qos=1)
            async with asyncio.timeout(60):
                while not any(m.get("event") == "completed" for _, m in seen):
                    await asyncio.sleep(0.05)
            await ground.stop()

    told = None  # the flight state of the last heartbeat
    ends = []  # the state told when each step's report came
    for channel, message in seen:
        if channel == "heartbeats":
            told = message["state"]
        elif channel == "mission" and message.get("event") == "step":
            ends.append((message["command"], told))
    assert [command for command, _ in ends] == ["arm", "takeoff", "land"], ends
    # Each report comes after a heartbeat of the state its step brought, or of a later one (at
    # 10x the vehicle may be further on when the report goes): armed before "arm" is reported,
    # in the air before "takeoff", landing (or down) before "land".
    needed = {"arm": "armed", "takeoff": "flying", "land": "landing"}
    assert all(ORDER.index(state) >= ORDER.index(needed[c]) for c, state in ends), ends


#: A flight's states in the order one flight goes through them (a landing ends disarmed).
ORDER = ["arming", "armed", "taking_off", "flying", "landing", "disarmed"]
