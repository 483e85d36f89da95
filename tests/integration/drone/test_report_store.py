"""A drone's reports survive a restart of its software (issue 13): nothing it did is lost.

A real ``dronefleet drone --state-dir`` flies a mission on its own Mosquitto. The broker is
killed (the drone flies on, its reports queue), then the drone itself is killed with SIGKILL
before it could send them. Restarted on the same state folder and asked for the mission's
reports, it sends every one, numbered 1..n without a gap, the steps flown while the broker was
away included, and then says the mission was interrupted (it does not fly it again).
"""

from __future__ import annotations

import asyncio

import orjson
import pytest

from dronefleet.messaging.client import BrokerClient
from support.brokers import Mosquitto
from support.processes import dronefleet, process, stop

pytestmark = pytest.mark.integration

HOME = (40.63, -8.659)


def mission() -> dict:
    steps: list[dict] = [{"command": "arm"}, {"command": "takeoff", "value": 10}]
    for i in range(10):
        steps += [
            {"command": "navigate", "lat": HOME[0] + 0.00012 * (i + 1), "lon": HOME[1],
             "altitude_delta": 10},
            {"command": "wait_for_flight"},
        ]  # fmt: skip
    return {"mission_id": "keep-1", "steps": steps}


async def test_reports_unsent_when_the_drone_was_killed_are_sent_after_its_restart(tmp_path):
    reports: list[dict] = []

    async def collect(_topic: str, payload: bytes) -> None:
        reports.append(orjson.loads(payload))

    def steps() -> set[int]:
        return {r["step_index"] for r in reports if r.get("event") == "step"}

    broker = Mosquitto(tmp_path)
    url = broker.start().full()
    cmd = dronefleet("drone", "--id", "QUAD_S", "--broker", url, "--fc", "sim",
                     "--home", f"{HOME[0]},{HOME[1]},10", "--speedup", "10",
                     "--state-dir", str(tmp_path / "state"))  # fmt: skip
    ground = BrokerClient(url, "keep-ground")
    await ground.subscribe("QUAD_S/mission/out", collect)
    await ground.start(timeout_s=20)
    try:
        with process(cmd, tmp_path / "drone-1.log") as first:
            async with asyncio.timeout(60):
                while not reports:  # subscribed: it answers a report request
                    await ground.publish("QUAD_S/mission/in", {"action": "report",
                                         "mission_id": "none"})  # fmt: skip
                    await asyncio.sleep(0.5)
            await ground.publish("QUAD_S/mission/in", mission())
            async with asyncio.timeout(60):
                while len(steps()) < 6:
                    await asyncio.sleep(0.05)
            heard = set(steps())
            broker.stop(kill=True)
            await asyncio.sleep(1.5)  # 15 vehicle seconds flown with nobody listening
            stop(first, sig_kill=True)
        broker.start()
        reports.clear()
        with process(cmd, tmp_path / "drone-2.log"):
            await ground.wait_connected(timeout_s=20)
            ask = {"action": "report", "mission_id": "keep-1", "request_id": "report-ask"}
            async with asyncio.timeout(60):
                while not any(r.get("event") == "rejected" for r in reports):
                    await ground.publish("QUAD_S/mission/in", ask)
                    await asyncio.sleep(1.0)
    finally:
        await ground.stop()
        broker.stop()

    kept = [r for r in reports if r["mission_id"] == "keep-1" and r.get("seq")]
    numbers = sorted({r["seq"] for r in kept})
    assert numbers == list(range(1, len(numbers) + 1)), numbers  # none missing
    assert steps() > heard, (steps(), heard)  # the steps flown while nobody listened
    said = next(r for r in reports if r.get("event") == "rejected")
    assert said["request_id"] == "report-ask" and "interrupted" in said["error"]
    assert not any(r.get("event") == "step" and r.get("seq") is None for r in reports)
    assert (tmp_path / "state" / "reports.db").stat().st_mode & 0o777 == 0o600
