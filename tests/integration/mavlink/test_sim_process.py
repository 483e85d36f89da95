"""Three processes, real bytes everywhere: ``dronefleet sim --count 3`` serves vehicles over
MAVLink/UDP, ``dronefleet drone --fc mavlink`` flies one of them, and an operator commands the
drone over MQTT (embedded broker). A control command moves the MAVLink vehicle.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator

import pytest

from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from support.drones import Operator, drone_process
from support.processes import dronefleet_process

from .conftest import HOME, free_udp_ports

pytestmark = pytest.mark.integration

HOME_ARG = f"{HOME.lat},{HOME.lon},{HOME.alt_m:g}"


@contextlib.asynccontextmanager
async def sim_process(count: int, base_port: int, *args: str) -> AsyncIterator[list[str]]:
    """``dronefleet sim`` as its own process until it says ready; yields its vehicle lines."""
    command = ("sim", "--count", str(count), "--mavlink", f"udp:127.0.0.1:{base_port}", *args)
    async with dronefleet_process(*command, ready="sim ready") as (_, lines):
        yield lines


async def position(op: Operator, drone_id: str) -> NED:
    answer = await op.command(drone_id, command="objrequest", value="GPSPosition")
    assert answer["ok"], answer
    pos = answer["result"]["data"]
    return lla_to_ned(LLA(pos["Latitude"], pos["Longitude"], pos["Altitude"]), HOME)


async def test_mqtt_command_moves_a_mavlink_vehicle_in_another_process(embedded_broker):
    base = free_udp_ports(3)
    async with sim_process(3, base, "--home", HOME_ARG, "--speedup", "10") as lines:
        assert sum(line.startswith("vehicle ") for line in lines) == 3
        # Vehicle 2 (system id 2) on the second port, away from the centre of the circle.
        url = f"udpout:127.0.0.1:{base + 1}"
        async with drone_process(embedded_broker, "QUAD_MAV", "--fc", "mavlink", "--fc-url", url):
            async with Operator(embedded_broker) as op:
                await op.heartbeat("QUAD_MAV")
                start = await position(op, "QUAD_MAV")
                assert start.horizontal_m > 5  # homes are spread out around HOME

                armed = await op.command("QUAD_MAV", command="arm")
                assert armed["ok"], armed
                # ArduPilot arms before it ACKs (issue 10, item 1): no 3 s wait any more
                assert armed["result"]["arming_time_s"] < 1.1
                took_off = await op.command("QUAD_MAV", command="takeoff", value=8)
                assert took_off["ok"], took_off

                goal = NED(start.n + 30, start.e - 20, -8)
                target = ned_to_lla(goal, HOME)
                moved = await op.command(
                    "QUAD_MAV", command="navigate", lat=target.lat, lon=target.lon,
                    altitude_delta=8,
                )  # fmt: skip
                assert moved["ok"], moved.get("error")
                loop = asyncio.get_running_loop()
                deadline = loop.time() + 30
                while (here := await position(op, "QUAD_MAV")) and (here - goal).norm_m > 1.5:
                    assert loop.time() < deadline, f"vehicle at {here}, wanted {goal}"
                    await asyncio.sleep(0.1)

                status = await op.command("QUAD_MAV", command="objrequest", value="FlightStatus")
                assert status["result"]["data"]["InAir"] is True
                raw = await op.command("QUAD_MAV", command="objrequest", value="HEARTBEAT")
                assert raw["result"]["data"]["custom_mode"] == 4  # GUIDED
                landed = await op.command("QUAD_MAV", command="land")
                assert landed["ok"], landed


def _system_ids(ports: list[int]) -> list[int]:
    """A pymavlink station's view: the system id heard on each port."""
    from pymavlink import mavutil

    seen = []
    for port in ports:
        conn = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255)
        try:
            beat = None
            for _ in range(20):
                conn.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, 8, 0, 0, 0)
                beat = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
                if beat is not None:
                    break
            assert beat is not None, f"nothing heard on {port}"
            seen.append(beat.get_srcSystem())
        finally:
            conn.close()
    return seen


async def test_two_sim_processes_with_sysid_base_never_share_a_system_id():
    """Issue 10, item 9: two ``dronefleet sim`` processes on one network both started at system
    id 1; ``--sysid-base`` gives the second its own range, as ArduPilot's MAV_SYSID would."""
    first, second = free_udp_ports(2), free_udp_ports(2)
    async with (
        sim_process(2, first, "--home", HOME_ARG),
        sim_process(2, second, "--home", HOME_ARG, "--sysid-base", "3"),
    ):
        ports = [first, first + 1, second, second + 1]
        ids = await asyncio.to_thread(_system_ids, ports)
    assert ids == [1, 2, 3, 4]
