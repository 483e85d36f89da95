"""The Logger (seed 3.3.2.5, 4.1.3) over a real embedded broker: one JSON line per message."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from dronefleet.clock import WallClock, wait_until
from dronefleet.drone.logger import DroneLogger
from dronefleet.messaging import topics
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.topics import Channel, Direction

DRONE = "QUAD_1"


def lines(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines()]


@pytest.fixture
async def drone_client(embedded_broker):
    async with BrokerClient(embedded_broker, "drone-logger") as client:
        yield client


@pytest.fixture
async def ground(embedded_broker):
    async with BrokerClient(embedded_broker, "ground") as client:
        yield client


async def test_every_message_on_the_drones_topics_becomes_one_line_on_disk(
    drone_client, ground, tmp_path: Path
) -> None:
    logger = DroneLogger(DRONE, drone_client, tmp_path / "logs")
    await logger.start()
    telemetry = {"drone_id": DRONE, "vehicle_time_s": 3.5, "fields": {"battery_pct": 87.0}}
    await ground.publish(topics.topic(DRONE, Channel.TELEMETRY, Direction.OUT), telemetry, qos=0)
    await ground.publish(topics.topic("HEXA_2", Channel.CONTROL, Direction.IN), {"command": "arm"})
    await ground.publish(topics.topic(DRONE, Channel.CONTROL, Direction.IN), b"arm now!")
    await ground.publish(topics.topic(DRONE, Channel.GEAR, Direction.IN), b"\xff\xfe{")
    assert await wait_until(
        WallClock(), lambda: logger.lines_written == 3, timeout_s=5, poll_s=0.01
    )

    # Read while the logger still runs: each line is flushed as it is written.
    first, second, third = lines(tmp_path / "logs" / f"{DRONE}.jsonl")
    await logger.stop()
    assert first["topic"] == f"{DRONE}/telemetry/out" and first["payload"] == telemetry
    assert isinstance(first["t"], float) and first["t"] > 1.6e9  # wall unix time
    assert second["topic"] == f"{DRONE}/control/in" and second["payload"] == {"raw": "arm now!"}
    assert third["payload"]["raw"].endswith("{")  # undecodable bytes replaced, not fatal


async def test_local_events_such_as_arming_switch_interactions_are_recorded(
    drone_client, tmp_path: Path
) -> None:
    logger = DroneLogger(DRONE, drone_client, tmp_path)
    await logger.start()
    logger.log_event("arm", requested_by="mission survey-7", vehicle_time_s=12.25)
    logger.log_event("decode", seconds=0.0031, odd={1: object()})  # not JSON: written as text
    (arm, decode) = lines(tmp_path / f"{DRONE}.jsonl")
    await logger.stop()
    assert arm["event"] == "arm"
    assert arm["data"] == {"requested_by": "mission survey-7", "vehicle_time_s": 12.25}
    assert decode["data"]["seconds"] == 0.0031 and decode["data"]["odd"]["1"].startswith("<object")


async def test_files_rotate_at_max_bytes_and_keep_the_newest_backups(
    drone_client, tmp_path: Path
) -> None:
    logger = DroneLogger(DRONE, drone_client, tmp_path, max_bytes=400, backups=2)
    await logger.start()
    for i in range(60):
        logger.log_event("tick", i=i)
    await logger.stop()

    base = tmp_path / f"{DRONE}.jsonl"
    files = [base, base.with_name(base.name + ".1"), base.with_name(base.name + ".2")]
    assert all(f.exists() and 0 < f.stat().st_size <= 400 for f in files)
    assert not base.with_name(base.name + ".3").exists()
    ticks = [[rec["data"]["i"] for rec in lines(f)] for f in reversed(files)]
    oldest_kept, older, newest = ticks
    assert newest[-1] == 59  # the live file has the latest line
    assert oldest_kept + older + newest == list(range(oldest_kept[0], 60))  # contiguous, in order


async def test_a_restarted_logger_appends_to_the_existing_file(
    drone_client, tmp_path: Path
) -> None:
    for run in range(2):
        logger = DroneLogger(DRONE, drone_client, tmp_path)
        await logger.start()
        logger.log_event("boot", run=run)
        await logger.stop()
    assert [rec["data"]["run"] for rec in lines(tmp_path / f"{DRONE}.jsonl")] == [0, 1]
