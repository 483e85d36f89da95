"""``--plume`` on a MAVLink drone (issue 28, item 6): before, ``dronefleet drone --fc mavlink
--plume ...`` ignored it, and collaboration on ArduPilot SITL needed an outside script sending
NAMED_VALUE_FLOAT "CO2". Now the companion computer's CO2 sensor is simulated over the
position the autopilot reports. Three processes, wall time: ``dronefleet sim`` (no plume of its
own: its CO2 is background) serves the vehicle over MAVLink, ``dronefleet drone --fc mavlink
--plume`` flies it over the plume, and the gear reading rises and a CO2 alarm reaches the
operator on ``<id>/alarms/out``.
"""

from __future__ import annotations

import asyncio

import pytest

from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.messaging import topics
from dronefleet.messaging.topics import Channel, Direction
from dronefleet.sim.gasfield import BACKGROUND_CO2_PPM
from support.drones import Operator
from support.processes import dronefleet_process

from .conftest import HOME, free_udp_ports

pytestmark = pytest.mark.integration

DRONE = "QUAD_GAS"


async def here(op: Operator) -> LLA:
    answer = await op.command(DRONE, command="objrequest", value="GPSPosition")
    assert answer["ok"], answer
    pos = answer["result"]["data"]
    return LLA(pos["Latitude"], pos["Longitude"], pos["Altitude"])


async def co2(op: Operator) -> dict:
    answer = await op.requester.request(
        topics.topic(DRONE, Channel.GEAR, Direction.IN),
        topics.topic(DRONE, Channel.GEAR, Direction.OUT),
        {"query": "reading", "sensor": "CO2"},
    )
    assert answer["ok"], answer
    return answer["reading"]


async def test_a_mavlink_drone_over_a_plume_reads_it_and_raises_the_alarm(embedded_broker):
    base = free_udp_ports(1)
    sim = ("sim", "--count", "1", "--mavlink", f"udp:127.0.0.1:{base}", "--speedup", "5",
           "--home", f"{HOME.lat},{HOME.lon},{HOME.alt_m:g}")  # fmt: skip
    async with dronefleet_process(*sim, ready="sim ready"):
        # The plume: 40 m north of the sim's home, centred on the ground, 3000 ppm at its centre.
        plume = ned_to_lla(NED(40, 0), HOME)
        drone = ("drone", "--id", DRONE, "--broker", embedded_broker.full(), "--fc", "mavlink",
                 "--fc-url", f"udpout:127.0.0.1:{base}", "--heartbeat-s", "1",
                 "--plume", f"{plume.lat},{plume.lon},3000,12")  # fmt: skip
        async with (
            dronefleet_process(*drone, ready="ready") as (_, lines),
            Operator(embedded_broker) as op,
        ):
            said = "".join(lines)
            assert "CO2 sensor simulated from --plume" in said, said
            await op.heartbeat(DRONE)
            start = await here(op)
            assert lla_to_ned(start, plume).horizontal_m > 30
            before = await co2(op)
            assert before["value"] == pytest.approx(BACKGROUND_CO2_PPM, abs=20)
            assert before["extra"]["simulated"] is True
            assert before["extra"]["source"] == "--plume"
            assert not op.alarms()

            assert (await op.command(DRONE, command="arm"))["ok"]
            assert (await op.command(DRONE, command="takeoff", value=10))["ok"]
            moved = await op.command(
                DRONE, command="navigate", lat=plume.lat, lon=plume.lon, altitude_delta=10
            )
            assert moved["ok"], moved.get("error")
            alarms = await op.wait_for(
                lambda: op.alarms("OUT_MEASURE"), timeout_s=60, key="alarms/out"
            )
            alarm = alarms[0]
            assert alarm["drone_id"] == DRONE
            assert alarm["reading"]["field"] == "co2_ppm"
            assert alarm["reading"]["value"] > 1000.0
            where = LLA(alarm["position"]["lat"], alarm["position"]["lon"])
            assert lla_to_ned(where, plume).horizontal_m < 20  # raised near the plume

            loop = asyncio.get_running_loop()
            deadline = loop.time() + 30
            while lla_to_ned(await here(op), plume).horizontal_m > 2:
                assert loop.time() < deadline, "never reached the plume"
                await asyncio.sleep(0.2)
            over = await co2(op)
            # 10 m above the centre: 420 + 3000 * exp(-100 / 288) = 2540 ppm
            assert over["value"] > 2000, over
            assert over["extra"]["simulated"] is True
            assert (await op.command(DRONE, command="land"))["ok"]
