"""The Fail-safe System (seed 3.3.2.4) over a real embedded broker: one alarm per crossing."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

from dronefleet.clock import WallClock, wait_until
from dronefleet.drone.failsafe import FailSafe, sensor_watch
from dronefleet.messaging import topics
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.codec import decode_object
from dronefleet.messaging.missions import MissionProgress, ProgressEvent
from dronefleet.messaging.status import Telemetry
from dronefleet.messaging.topics import Channel, Direction

DRONE = "QUAD_1"
TELEMETRY_OUT = topics.topic(DRONE, Channel.TELEMETRY, Direction.OUT)
MISSION_OUT = topics.topic(DRONE, Channel.MISSION, Direction.OUT)
ALARMS_OUT = topics.topic(DRONE, Channel.ALARMS, Direction.OUT)
AVEIRO = {"lat": 40.6303, "lon": -8.6575, "alt_m": 35.0, "relative_alt_m": 30.0}


class Vehicle:
    """Plays the Drone Controller and the Gear Manager: publishes this drone's telemetry."""

    def __init__(self, client: BrokerClient) -> None:
        self.client = client
        self.t = 0.0

    async def send(self, **fields: float) -> None:
        self.t += 1.0
        message = Telemetry(drone_id=DRONE, vehicle_time_s=self.t, fields=fields)
        await self.client.publish(TELEMETRY_OUT, message, qos=1)

    async def battery(self, *levels: float) -> None:
        for pct in levels:
            await self.send(battery_pct=pct, **AVEIRO)

    async def co2(self, *ppms: float) -> None:
        for ppm in ppms:
            await self.send(co2_ppm=ppm)


class Alarms:
    """What the ground hears on ``<id>/alarms/out``."""

    def __init__(self) -> None:
        self.queue: asyncio.Queue[dict[str, Any]] = asyncio.Queue()

    async def on_message(self, _topic: str, payload: bytes) -> None:
        await self.queue.put(decode_object(payload))

    async def take(self, count: int) -> list[dict[str, Any]]:
        return [await asyncio.wait_for(self.queue.get(), 5.0) for _ in range(count)]

    async def take_until_marker(self, vehicle: Vehicle) -> list[dict[str, Any]]:
        """All alarms before a marker excursion: alarms leave in order, so nothing is still due."""
        await vehicle.co2(99_999.0, 0.0)
        got = []
        while True:
            alarm = await asyncio.wait_for(self.queue.get(), 5.0)
            if (alarm.get("reading") or {}).get("value") == 99_999.0:
                return got
            got.append(alarm)


@pytest.fixture
async def failsafe(embedded_broker):
    async with BrokerClient(embedded_broker, "drone-failsafe") as client:
        fs = FailSafe(DRONE, client, WallClock(), sensor_bounds={"co2_ppm": (None, 1000.0)})
        await fs.start()
        yield fs
        await fs.stop()


@pytest.fixture
async def ground(embedded_broker):
    async with BrokerClient(embedded_broker, "ground") as client:
        yield client


@pytest.fixture
async def alarms(ground) -> Alarms:
    inbox = Alarms()
    await ground.subscribe(ALARMS_OUT, inbox.on_message)
    return inbox


@pytest.fixture
def vehicle(ground) -> Vehicle:
    return Vehicle(ground)


async def test_a_battery_that_crosses_20_pct_raises_exactly_one_critical_alarm(
    failsafe, vehicle, alarms
) -> None:
    # A noisy gauge hovering around the threshold, never back above 25 %.
    await vehicle.battery(31.0, 24.0, 20.5, 19.8, 19.6, 20.4, 21.9, 19.2, 17.0)
    got = await alarms.take_until_marker(vehicle)
    assert len(got) == 1
    alarm = got[0]
    assert alarm["level"] == "CRITICAL" and alarm["drone_id"] == DRONE
    assert alarm["message"] == "battery 19.8% below 20% threshold"
    assert alarm["position"] == AVEIRO
    assert alarm["reading"] == {"field": "battery_pct", "value": 19.8, "low": 20.0, "high": None}
    assert alarm["vehicle_time_s"] == 4.0  # the fourth telemetry message crossed


async def test_a_battery_swap_rearms_the_critical_alarm(failsafe, vehicle, alarms) -> None:
    await vehicle.battery(19.0, 24.9, 18.0, 100.0, 60.0, 19.9)
    got = await alarms.take_until_marker(vehicle)
    assert [a["reading"]["value"] for a in got] == [19.0, 19.9]
    assert {a["level"] for a in got} == {"CRITICAL"}


async def test_a_co2_plume_raises_one_out_measure_alarm_per_excursion(
    failsafe, vehicle, alarms
) -> None:
    await vehicle.battery(90.0)  # the first position fix
    # Out at 1200; 980 is inside but within the 5 % band (950), so 1100 is the same excursion;
    # 900 re-arms, and 1050 is a new one.
    await vehicle.co2(415.0, 800.0, 1200.0, 1300.0, 980.0, 1100.0, 900.0, 1050.0, 500.0)
    got = await alarms.take_until_marker(vehicle)
    assert [a["level"] for a in got] == ["OUT_MEASURE", "OUT_MEASURE"]
    assert [a["reading"]["value"] for a in got] == [1200.0, 1050.0]
    assert got[0]["reading"] == {"field": "co2_ppm", "value": 1200.0, "low": None, "high": 1000.0}
    assert "co2_ppm 1200 above" in got[0]["message"]
    assert got[0]["position"] == AVEIRO  # last known position: CO2 telemetry carries none


async def test_alarms_name_the_mission_and_step_being_flown(
    failsafe, vehicle, alarms, ground
) -> None:
    progress = MissionProgress(
        drone_id=DRONE, mission_id="survey-7", event=ProgressEvent.STEP, step_index=12
    )
    await ground.publish(MISSION_OUT, progress)
    assert await wait_until(
        WallClock(), lambda: failsafe.step_index == 12, timeout_s=5, poll_s=0.01
    )
    await vehicle.battery(15.0)
    (alarm,) = await alarms.take(1)
    assert alarm["mission_id"] == "survey-7" and alarm["step_index"] == 12

    done = MissionProgress(drone_id=DRONE, mission_id="survey-7", event=ProgressEvent.COMPLETED)
    await ground.publish(MISSION_OUT, done)
    assert await wait_until(
        WallClock(), lambda: failsafe.mission_id is None, timeout_s=5, poll_s=0.01
    )


async def test_an_alarm_before_the_first_position_fix_waits_for_it(
    failsafe, vehicle, alarms
) -> None:
    await vehicle.send(battery_pct=12.0)  # no GPS fix yet
    await vehicle.send(lat=40.0, lon=-8.0, alt_m=12.0)
    (alarm,) = await alarms.take(1)
    assert alarm["level"] == "CRITICAL" and alarm["vehicle_time_s"] == 1.0
    assert alarm["position"] == {"lat": 40.0, "lon": -8.0, "alt_m": 12.0}


async def test_garbage_on_the_telemetry_topic_does_not_stop_the_fail_safe(
    failsafe, vehicle, alarms, ground
) -> None:
    for junk in (
        b"\xff\xfe",
        b"[1, 2]",
        b'{"fields": "none"}',
        b'{"fields": {"battery_pct": "low"}}',
    ):
        await ground.publish(TELEMETRY_OUT, junk)
    await ground.publish(
        TELEMETRY_OUT,
        {
            "drone_id": DRONE,
            "vehicle_time_s": 0.5,
            "fields": {"battery_pct": 5, "lat": 91, "lon": 0, "alt_m": 0},
        },
    )
    await vehicle.battery(10.0)
    (alarm,) = await alarms.take(1)
    # The battery crossed in the message with the impossible position: it waited for a real one.
    assert alarm["reading"]["value"] == 5 and alarm["position"] == AVEIRO


def test_sensor_bounds_on_both_sides_use_5_pct_of_the_band_as_hysteresis() -> None:
    temperature = sensor_watch("temperature_c", -10.0, 40.0)  # re-arms 2.5 inside either bound
    assert temperature.update(41.0) == "high"
    assert temperature.update(38.0) is None and temperature.side == "high"
    assert temperature.update(-11.0) == "low"  # straight to the other side: a new excursion
    assert temperature.update(-8.0) is None and temperature.side == "low"
    assert temperature.update(-7.5) is None and temperature.side is None
    with pytest.raises(ValueError, match=r"low 5\.0 is above high 1\.0"):
        sensor_watch("x", 5.0, 1.0)
