"""A drone flies on through its broker's outage, and every report reaches the ground after it.

Issue 13: a drone's own broker killed for 30 s made it stop flying its mission (39/56 waypoints):
the Mission Worker awaited each progress report. Now reports go through an outbox
(drone/outbox.py). A real Mosquitto (persistent, so the listener's session survives it) is
stopped mid-mission and started again on the same port; a real `dronefleet drone` process flies.
"""

from __future__ import annotations

import asyncio
import itertools

import orjson
import pytest

from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.embedded import free_port
from support.brokers import mosquitto
from support.processes import dronefleet, process

pytestmark = pytest.mark.integration

SPEEDUP = 10
OUTAGE_WALL_S = 3.0
WAYPOINTS = 8


def mission() -> dict:
    steps: list[dict] = [{"command": "arm"}, {"command": "takeoff", "value": 10}]
    for i in range(WAYPOINTS):
        lat = 40.63 + 0.00012 * (i + 1)  # ~13 m apart
        steps += [
            {"command": "navigate", "lat": lat, "lon": -8.659, "altitude_delta": 10},
            {"command": "wait_for_flight"},
        ]
    return {"mission_id": "outage-1", "steps": [*steps, {"command": "land"}]}


async def test_the_drone_flies_on_through_a_broker_outage_and_no_report_is_lost(tmp_path):
    port = free_port()
    url = f"mqtt://127.0.0.1:{port}"
    reports: list[dict] = []

    async def collect(_topic: str, payload: bytes) -> None:
        reports.append(orjson.loads(payload))

    def events(kind: str) -> int:
        return sum(r.get("event") == kind for r in reports)

    broker = mosquitto(tmp_path, port=port, persistent=True)
    broker.__enter__()
    try:
        drone = dronefleet("drone", "--id", "QUAD_1", "--broker", url, "--fc", "sim",
                           "--home", "40.63,-8.659,10", "--speedup", str(SPEEDUP))  # fmt: skip
        with process(drone, tmp_path / "drone.log"):
            ground = BrokerClient(url, "outage-ground", persistent_session=True)
            beats: list[bytes] = []

            async def beat(_topic: str, payload: bytes) -> None:
                beats.append(payload)

            await ground.subscribe("QUAD_1/mission/out", collect, qos=1)
            await ground.subscribe("QUAD_1/heartbeats/out", beat)
            await ground.start(timeout_s=20)
            async with asyncio.timeout(60):  # the drone is up: it publishes only once subscribed
                while not beats:
                    await asyncio.sleep(0.05)
            await ground.publish("QUAD_1/mission/in", mission(), qos=1)
            async with asyncio.timeout(60):
                while events("step") < 4:
                    await asyncio.sleep(0.05)
            # The broker goes away mid-mission (stopped cleanly, so it keeps the ground's
            # session on disk) and comes back on the same port.
            broker.__exit__(None, None, None)
            await asyncio.sleep(OUTAGE_WALL_S)
            broker = mosquitto(tmp_path, port=port, persistent=True)
            broker.__enter__()
            async with asyncio.timeout(60):
                while not events("completed"):
                    await asyncio.sleep(0.1)
            await ground.stop()
    finally:
        broker.__exit__(None, None, None)

    steps = {r["step_index"]: r for r in reports if r.get("event") == "step"}
    assert sorted(steps) == list(range(len(mission()["steps"])))  # every step, none lost
    times = sorted(r["vehicle_time_s"] for r in steps.values())
    gap = max(b - a for a, b in itertools.pairwise(times))
    # The mission never waited for the broker: no step took the outage's vehicle seconds.
    assert gap < OUTAGE_WALL_S * SPEEDUP / 2, times
