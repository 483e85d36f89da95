"""An orphaned vehicle goes home by itself, and a live drone never trips its failsafe (issue 26,
item 3). Wall time, real processes: ``dronefleet drone --fc mavlink`` flies a simulated ArduPilot
Copter (our MAVLink endpoint, in this process, 5 times faster than the wall clock).

- At connect the drone turns the autopilot's GCS failsafe on: FS_GCS_ENABLE 1 (RTL), FS_OPTIONS
  bit 3 (a landing goes on), and its heartbeats say so.
- Alive, it heartbeats the autopilot every second of the autopilot's clock (every 0.2 wall s
  here): hovering 100 vehicle s never trips it. Before, it beat once a wall second, 5 vehicle s
  apart: FS_GCS_TIMEOUT's 5 s, and the failsafe tripped on a live drone.
- Its process killed (SIGKILL) while the vehicle hovers in GUIDED, the vehicle says "GCS
  Failsafe" and returns home FS_GCS_TIMEOUT vehicle seconds after the last heartbeat, and lands
  there. Before, it hovered until its battery was flat.
"""

from __future__ import annotations

import asyncio
import signal

import pytest

from dronefleet.experiments.fleets import free_udp_port
from dronefleet.protocols.mavlink.modes import CopterMode
from dronefleet.sim.mavlink import MavlinkSimServer
from dronefleet.sim.world import SimWorld
from support.drones import Operator, drone_process

from .conftest import HOME

pytestmark = pytest.mark.integration

SPEEDUP = 5.0


async def until(predicate, timeout_s: float, step_s: float = 0.05) -> None:
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while not predicate():
        assert loop.time() < deadline, "condition not met in time"
        await asyncio.sleep(step_s)


async def test_the_autopilot_brings_an_orphan_home_and_never_fails_safe_on_a_live_drone(
    embedded_broker,
):
    world = SimWorld(speedup=SPEEDUP)
    server = MavlinkSimServer(world)
    endpoint = server.add_vehicle(HOME, port=free_udp_port())
    copter, vehicle = endpoint.copter, endpoint.copter.vehicle
    assert copter.params.get("FS_GCS_ENABLE") == 0  # ArduPilot's default
    url = f"udpout:127.0.0.1:{endpoint.port}"
    args = ("--fc", "mavlink", "--fc-url", url, "--heartbeat-s", "1")
    async with server, Operator(embedded_broker) as op:
        async with drone_process(embedded_broker, "QUAD_FS", *args) as proc:
            assert copter.params.get("FS_GCS_ENABLE") == 1  # set at connect: RTL
            assert int(copter.params.get("FS_OPTIONS")) & 8  # its own landing goes on
            beat = await op.heartbeat("QUAD_FS")
            assert beat["link_failsafe"] == {
                "action": "rtl", "timeout_s": 5.0, "set_by_drone": True
            }  # fmt: skip

            assert (await op.command("QUAD_FS", command="arm"))["ok"]
            assert (await op.command("QUAD_FS", command="takeoff", value=10))["ok"]
            await until(lambda: vehicle.relative_alt_m > 9.5, timeout_s=20)
            # Alive: 20 wall s, 100 vehicle s of hovering, and never a failsafe.
            since = vehicle.time_s
            tripped = []
            loop = asyncio.get_running_loop()
            end = loop.time() + 20.0
            gaps = []
            last = copter.gcs_last_seen_s
            while loop.time() < end:
                tripped.append(copter.gcs_failsafe)
                if copter.gcs_last_seen_s != last:
                    gaps.append(copter.gcs_last_seen_s - last)
                    last = copter.gcs_last_seen_s
                await asyncio.sleep(0.02)
            print("vehicle s hovered", round(vehicle.time_s - since, 1), "beats", len(gaps),
                  "largest gap (vehicle s)", round(max(gaps), 2))  # fmt: skip
            assert vehicle.time_s - since > 60.0
            assert not any(tripped) and copter.mode is CopterMode.GUIDED
            assert max(gaps) < 2.5  # every second of its clock, give or take the machine

            proc.send_signal(signal.SIGKILL)  # the drone software dies, the copter hovers
            await proc.wait()
            killed_at = copter.gcs_last_seen_s
            await until(lambda: copter.mode is CopterMode.RTL, timeout_s=10)
            after = vehicle.time_s - killed_at
            print("RTL", round(after, 2), "vehicle s after the last heartbeat")
            assert copter.gcs_failsafe
            assert 5.0 <= after < 6.5  # FS_GCS_TIMEOUT, on the autopilot's clock
            await until(lambda: not vehicle.armed, timeout_s=40, step_s=0.2)
            assert vehicle.position_ned.horizontal_m < 2.0  # landed at home
