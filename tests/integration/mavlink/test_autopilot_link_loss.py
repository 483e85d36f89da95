"""The autopilot's link lost mid-mission is a mission event, and a rebooted autopilot's drone beats
on with a clock that runs (issue 26, item 5).

Before: the mission went on waiting for a goal the vehicle could not be told about (or failed
its next step with "not connected") and nobody was told why; after the autopilot rebooted, the
drone's clock stood still for as long as the autopilot had been away, so its heartbeats stopped
and the ground would call it lost. A DroneApp on the MAVLink backend flies a simulated ArduPilot
Copter over loopback UDP; the vehicle's endpoint goes silent mid-mission and comes back with a
rebooted autopilot (its boot time from zero; the simulated vehicle fell: a reboot in flight).
"""

from __future__ import annotations

import asyncio
import itertools

import pytest

from dronefleet.drone.app import DroneApp
from dronefleet.drone.config import DroneConfig
from dronefleet.drone.fc import mavlink as mavlink_fc
from dronefleet.drone.takeover import LINK_LOST
from dronefleet.experiments.fleets import free_udp_port
from dronefleet.sim.mavlink import MavlinkSimServer
from dronefleet.sim.world import SimWorld
from support.drones import Operator

from .conftest import HOME
from .test_takeover import line

pytestmark = pytest.mark.integration


def events(op: Operator, kind: str) -> list[dict]:
    return [p for p in op.progress("ll") if p["event"] == kind]


def beats(op: Operator) -> list[dict]:
    return [h for h in op.received["heartbeats/out"] if h["drone_id"] == "QUAD_L"]


async def test_a_lost_autopilot_pauses_the_mission_and_a_rebooted_one_beats_on(embedded_broker):
    world = SimWorld(speedup=10)
    server = MavlinkSimServer(world)
    endpoint = server.add_vehicle(HOME, port=free_udp_port())
    loop = asyncio.get_running_loop()
    async with server, Operator(embedded_broker) as op:
        fc = await mavlink_fc.open_flight_controller(f"udpout:127.0.0.1:{endpoint.port}")
        sensors, _camera = mavlink_fc.payload(fc)
        app = DroneApp(DroneConfig(drone_id="QUAD_L"), fc, embedded_broker, sensors=sensors)
        await app.start()
        try:
            await op.send_mission("QUAD_L", mission_id="ll", steps=line(8))
            await op.wait_for(lambda: len(events(op, "step")) >= 4, timeout_s=60)

            endpoint.close()  # the autopilot goes silent mid-mission
            silent_at = loop.time()
            (paused,) = await op.wait_for(lambda: events(op, "paused"), timeout_s=10)
            assert loop.time() - silent_at < 5.0, "not a mission event within 5 s"
            assert paused["error"].startswith("paused: the autopilot link is lost"), paused
            assert paused["result"]["by"] == LINK_LOST
            assert not events(op, "failed") and not events(op, "completed")

            await asyncio.sleep(3.0)  # away 6 s of wall time in all, 60 vehicle s
            heard = len(beats(op))
            await endpoint.start()
            endpoint.copter.reboot(force=True)  # it rebooted (and fell: a sim), silent until up

            def linked() -> bool:
                return bool(beats(op)) and beats(op)[-1]["autopilot_link"]

            await op.wait_for(linked, 20, key="heartbeats/out")
            await asyncio.sleep(2.0)
            # Heartbeats every 5 vehicle s (0.5 wall s here) went on through it all: the clock
            # runs on (before, it stood still for the 60 s it had said already: 6 s of wall).
            after = beats(op)[heard - 1 :]  # from the last one before the autopilot came back
            sent = [b["timestamp"] for b in after]
            gaps = [b - a for a, b in itertools.pairwise(sent)]
            assert len(after) >= 3 and max(gaps) < 1.5, [
                (b["vehicle_time_s"], b["autopilot_link"]) for b in after
            ]
            times = [b["vehicle_time_s"] for b in after]
            assert times == sorted(times) and times[-1] - times[0] >= 15.0, times
            assert after[-1]["autopilot_link"]
            assert fc.clock.boot_count >= 1  # the reboot was seen
            # The mission waits for the operator (on the ground now: a resume is refused).
            assert app.mission_worker.paused is not None
            assert not events(op, "failed")
        finally:
            await app.stop()
