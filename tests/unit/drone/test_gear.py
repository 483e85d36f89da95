"""The Gear Manager (seed 3.3.2.3, 4.1.4) over a real embedded broker."""

from __future__ import annotations

import asyncio
import itertools
import json
import logging
import time
from pathlib import Path
from typing import Any

import pytest

from dronefleet.clock import Clock, WallClock, wait_until
from dronefleet.drone.gear import GearManager, telemetry_field
from dronefleet.messaging import topics
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.codec import decode_object
from dronefleet.messaging.rpc import Requester
from dronefleet.messaging.topics import Channel, Direction
from dronefleet.vehicle.payload import Reading

DRONE = "QUAD_1"
GEAR_IN = topics.topic(DRONE, Channel.GEAR, Direction.IN)
GEAR_OUT = topics.topic(DRONE, Channel.GEAR, Direction.OUT)
TELEMETRY_OUT = topics.topic(DRONE, Channel.TELEMETRY, Direction.OUT)

SEED_SPECS = {
    "TYPE": "HEXACOPTER",
    "FRAME_SIZE": "550",
    "BATTERY": {"CELL_COUNT": 4, "CAPACITY": 5500},
}
SEED_SENSORS = {"GAS": {"CO2": "Sensirion SCD30"}, "CAMERA": "GoPro Hero3"}


class FastClock:
    """Vehicle time running ``speedup`` times faster than the wall, like a sped-up simulation."""

    def __init__(self, speedup: float = 20.0) -> None:
        self.speedup = speedup
        self._t0 = time.monotonic()

    def now(self) -> float:
        return (time.monotonic() - self._t0) * self.speedup

    async def sleep(self, duration_s: float) -> None:
        await asyncio.sleep(max(0.0, duration_s) / self.speedup)


class CO2Sensor:
    name = "CO2"
    unit = "ppm"

    def __init__(self, clock: Clock, ppm: float = 415.0) -> None:
        self.clock = clock
        self.ppm = ppm

    def read(self) -> Reading:
        return Reading("CO2", self.ppm, "ppm", self.clock.now())


class BrokenSensor:
    name = "Humidity"
    unit = "%"

    def read(self) -> Reading:
        raise OSError("I2C bus timeout")


class GoPro:
    name = "GoPro Hero3"

    def __init__(self) -> None:
        self.index = 0

    def capture(self) -> dict[str, Any]:
        self.index += 1
        return {
            "lat": 40.6,
            "lon": -8.65,
            "alt_m": 30.0,
            "vehicle_time_s": 1.0,
            "index": self.index,
        }


@pytest.fixture
async def drone_client(embedded_broker):
    async with BrokerClient(embedded_broker, "drone-gear") as c:
        yield c


@pytest.fixture
async def ground(embedded_broker):
    async with BrokerClient(embedded_broker, "ground") as c:
        yield c


@pytest.fixture
def clock() -> FastClock:
    return FastClock()


async def ask(ground: BrokerClient, **request: Any) -> dict[str, Any]:
    return await Requester(ground).request(GEAR_IN, GEAR_OUT, request, timeout_s=5.0)


async def start_manager(drone_client, clock, **kwargs: Any) -> GearManager:
    kwargs.setdefault("gear_dir", None)
    manager = GearManager(DRONE, drone_client, clock, **kwargs)
    await manager.start()
    return manager


async def test_a_drone_without_a_gear_dir_describes_itself_with_the_seed_listings(
    drone_client, ground, clock
) -> None:
    manager = await start_manager(drone_client, clock)
    try:
        specs = await ask(ground, query="specs")
        sensors = await ask(ground, query="sensors")
    finally:
        await manager.stop()
    assert specs["ok"] and specs["drone_id"] == DRONE and specs["query"] == "specs"
    assert specs["specs"] == SEED_SPECS  # Listing 4.1
    assert sensors["sensors"] == SEED_SENSORS  # Listing 4.2


async def test_an_edited_specs_file_shows_up_at_the_next_reread(
    drone_client, ground, clock, tmp_path: Path
) -> None:
    (tmp_path / "specs.json").write_text(json.dumps(SEED_SPECS))
    manager = await start_manager(drone_client, clock, gear_dir=tmp_path, reread_s=2.0)
    try:
        assert (await ask(ground, query="specs"))["specs"]["TYPE"] == "HEXACOPTER"
        quad = {**SEED_SPECS, "TYPE": "QUADCOPTER", "BATTERY": {"CELL_COUNT": 3, "CAPACITY": 2200}}
        (tmp_path / "specs.json").write_text(json.dumps(quad))
        # Picked up at the next re-read (every 2 vehicle seconds), not at once.
        assert manager.specs["TYPE"] == "HEXACOPTER"
        assert await wait_until(clock, lambda: manager.specs["TYPE"] == "QUADCOPTER", timeout_s=20)
        reply = await ask(ground, query="specs")
    finally:
        await manager.stop()
    assert reply["specs"]["TYPE"] == "QUADCOPTER"
    assert reply["specs"]["BATTERY"] == {"CELL_COUNT": 3, "CAPACITY": 2200}
    # sensors.json is missing from the directory: the built-in list stands in.
    assert manager.sensor_list == SEED_SENSORS


async def test_a_malformed_file_is_logged_and_the_last_good_content_kept(
    drone_client, ground, clock, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    sensors = {"GAS": {"CO2": "Sensirion SCD30", "CH4": "MQ-4"}}
    (tmp_path / "sensors.json").write_text(json.dumps(sensors))
    manager = await start_manager(drone_client, clock, gear_dir=tmp_path, reread_s=3600.0)
    try:
        (tmp_path / "sensors.json").write_text('{"GAS": {"CO2": ')  # saved half-way
        (tmp_path / "specs.json").write_text('{"TYPE": "QUAD"}')  # no frame size, no battery
        with caplog.at_level(logging.WARNING, logger="dronefleet.drone.gear"):
            manager.reload()
        reply = await ask(ground, query="sensors")
    finally:
        await manager.stop()
    assert reply["ok"] and reply["sensors"] == sensors
    assert manager.specs == SEED_SPECS
    assert "sensors.json is malformed" in caplog.text
    assert "specs.json is malformed" in caplog.text and "BATTERY" in caplog.text


async def test_a_sensor_is_read_by_name_and_an_unknown_one_is_refused_with_the_list(
    drone_client, ground, clock
) -> None:
    manager = await start_manager(drone_client, clock, sensors={"CO2": CO2Sensor(clock, 612.0)})
    try:
        reading = await ask(ground, query="reading", sensor="co2")
        unknown = await ask(ground, query="reading", sensor="CH4")
        unnamed = await ask(ground, query="reading")
    finally:
        await manager.stop()
    assert reading["ok"]
    assert reading["reading"]["sensor"] == "CO2"
    assert reading["reading"]["value"] == 612.0 and reading["reading"]["unit"] == "ppm"
    assert not unknown["ok"] and "no sensor 'CH4'" in unknown["error"] and "CO2" in unknown["error"]
    assert not unnamed["ok"] and "name a sensor" in unnamed["error"]


async def test_capture_takes_a_picture_and_a_drone_without_a_camera_says_so(
    drone_client, ground, clock
) -> None:
    manager = await start_manager(drone_client, clock, camera=GoPro())
    try:
        first = await ask(ground, query="capture")
        second = await ask(ground, query="capture")
    finally:
        await manager.stop()
    assert first["ok"] and first["capture"]["index"] == 1 and second["capture"]["index"] == 2

    bare = await start_manager(drone_client, clock)
    try:
        reply = await ask(ground, query="capture")
    finally:
        await bare.stop()
    assert not reply["ok"] and "no camera" in reply["error"]


async def test_malformed_and_unknown_requests_get_a_reason_and_the_manager_keeps_answering(
    drone_client, ground, clock
) -> None:
    replies: asyncio.Queue[dict[str, Any]] = asyncio.Queue()

    async def collect(_topic: str, payload: bytes) -> None:
        await replies.put(decode_object(payload))

    await ground.subscribe(GEAR_OUT, collect)
    manager = await start_manager(drone_client, clock)
    try:
        await ground.publish(GEAR_IN, b"this is not JSON")
        await ground.publish(GEAR_IN, {"request_id": "r1", "query": "weather"})
        await ground.publish(GEAR_IN, {"request_id": "r2", "query": "specs", "colour": "red"})
        await ground.publish(GEAR_IN, {"request_id": "r3", "query": "specs"})
        got = [await asyncio.wait_for(replies.get(), 5.0) for _ in range(4)]
    finally:
        await manager.stop()
    not_json, unknown, extra, good = got
    assert not not_json["ok"] and "not valid JSON" in not_json["error"]
    assert unknown["request_id"] == "r1" and not unknown["ok"] and "query" in unknown["error"]
    assert extra["request_id"] == "r2" and not extra["ok"] and "colour" in extra["error"]
    assert good["request_id"] == "r3" and good["ok"] and good["specs"] == SEED_SPECS


@pytest.mark.virtual_time
async def test_sensors_stream_as_telemetry_sample_hz_times_per_vehicle_second(
    drone_client, ground
) -> None:
    """On virtual time, so the rate is measured in vehicle seconds whatever the host's load: on
    ``FastClock`` (wall time x 20) a loaded CI host woke the sampler late enough to skip a
    period (mean gap 0.63 s)."""
    clock = WallClock()  # the loop's time: virtual here
    samples: list[dict[str, Any]] = []

    async def collect(_topic: str, payload: bytes) -> None:
        samples.append(decode_object(payload))

    await ground.subscribe(TELEMETRY_OUT, collect, qos=0)
    sensors = {"CO2": CO2Sensor(clock, 415.0), "Humidity": BrokenSensor()}
    manager = await start_manager(drone_client, clock, sensors=sensors, sample_hz=2.0)
    started = clock.now()
    await clock.sleep(5.0)  # 5 vehicle seconds: about 10 samples at 2 Hz
    await manager.stop()
    elapsed = clock.now() - started
    await asyncio.sleep(0.05)

    assert elapsed == pytest.approx(5.0)
    assert len(samples) in (9, 10)  # at 2 Hz; the last one may fall after the stop
    # The broken humidity sensor is left out; CO2 keeps streaming.
    assert all(s["fields"] == {"co2_ppm": 415.0} for s in samples)
    assert all(s["drone_id"] == DRONE for s in samples)
    times = [s["vehicle_time_s"] for s in samples]
    assert times == sorted(times)
    gaps = [b - a for a, b in itertools.pairwise(times)]
    assert gaps == pytest.approx([0.5] * len(gaps), abs=1e-6)


def test_telemetry_field_names_are_sensor_and_unit() -> None:
    assert telemetry_field("CO2", "ppm") == "co2_ppm"
    assert telemetry_field("Humidity", "%") == "humidity_pct"
    assert telemetry_field("PM2.5", "µg/m3") == "pm2_5_ug_m3"
