"""A mission uploaded over MAVLink keeps being flown while the broker is down, and its progress
reaches the ground when the broker comes back (issue 6, Must show 3).

A Mosquitto of the test's own is stopped mid-mission and started again on the same port; the drone
(DroneApp on the MAVLink backend, simulated Copter over UDP) flies on board meanwhile.
"""

from __future__ import annotations

import asyncio
import time

import pytest

from dronefleet.drone.app import DroneApp
from dronefleet.drone.config import DroneConfig
from dronefleet.drone.fc import mavlink as mavlink_fc
from dronefleet.experiments.fleets import free_udp_port
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.codec import decode_object
from dronefleet.messaging.embedded import free_port
from dronefleet.sim.mavlink import MavlinkSimServer
from dronefleet.sim.world import SimWorld
from support.brokers import mosquitto

pytestmark = pytest.mark.integration

HOME = LLA(40.63, -8.659, 10.0)


def mission_steps() -> list[dict]:
    steps: list[dict] = [{"command": "arm"}, {"command": "takeoff", "value": 10}]
    for n, e in ((60, 0), (60, 60), (0, 60)):
        p = ned_to_lla(NED(n, e), HOME)
        steps += [
            {"command": "navigate", "lat": p.lat, "lon": p.lon},
            {"command": "wait_for_flight"},
        ]
    steps.insert(5, {"command": "sleep", "value": 3})
    return [*steps, {"command": "takepic"}, {"command": "land"}]


async def test_onboard_mission_flies_through_a_broker_outage_and_reports_afterwards(tmp_path):
    port = free_port()
    persist = f"persistence true\npersistence_location {tmp_path}/\n"
    world = SimWorld(speedup=10)
    server = MavlinkSimServer(world)
    endpoint = server.add_vehicle(HOME, port=free_udp_port())
    vehicle = endpoint.copter.vehicle
    received: list[tuple[float, dict]] = []
    steps = mission_steps()
    async with server:
        with mosquitto(tmp_path, persist, port=port) as url:
            fc = await mavlink_fc.open_flight_controller(f"udpout:127.0.0.1:{endpoint.port}")
            sensors, camera = mavlink_fc.payload(fc)
            config = DroneConfig(drone_id="QUAD_M", heartbeat_interval_s=1.0)
            config.onboard_missions = True  # what onboard.wanted() looks for
            app = DroneApp(config, fc, url, sensors=sensors, camera=camera)
            await app.start()
            observer = BrokerClient(url, "observer-outage", persistent_session=True)
            await observer.start()

            async def record(_topic: str, payload: bytes) -> None:
                received.append((time.monotonic(), decode_object(payload)))

            await observer.subscribe("QUAD_M/mission/out", record)
            await observer.publish("QUAD_M/mission/in", {"mission_id": "M-out", "steps": steps})
            await until(lambda: any(m.get("step_index") == 1 for _, m in received), 30)
        # The broker is down (process ended). The vehicle flies the rest on its own.
        down_at = time.monotonic()
        start = vehicle.position_ned
        await until(lambda: not vehicle.armed, 60)  # flown to the end and landed, disarmed
        travelled = (vehicle.position_ned - start).norm_m
        assert travelled > 50, f"the vehicle moved only {travelled:.1f} m while the broker was down"
        during = [m for t, m in received if t > down_at]
        assert not during, "nothing can arrive while the broker is down"
        with mosquitto(tmp_path, persist, port=port):
            back_at = time.monotonic()
            try:
                await until(lambda: any(m["event"] == "completed" for _, m in received), 30)
            finally:
                await observer.stop()
                await app.stop()
    progress = [m for _, m in received if m["mission_id"] == "M-out"]
    done = [m["step_index"] for m in progress if m["event"] == "step"]
    assert done == list(range(len(steps))), progress
    after = [m for t, m in received if t >= back_at]
    assert {m["step_index"] for m in after if m["event"] == "step"} >= set(range(3, len(steps)))
    # Reports carry the autopilot's time of the event, not of their delivery.
    times = [m["vehicle_time_s"] for m in progress if m["event"] == "step"]
    assert times == sorted(times)
    steps_done = [m for m in progress if m["event"] == "step"]
    assert all(m["result"] == {"on_board": True} for m in steps_done[1:])  # arm: from here


async def until(predicate, timeout_s: float) -> None:
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while not predicate():
        if loop.time() > deadline:
            raise TimeoutError(f"condition not met within {timeout_s} s")
        await asyncio.sleep(0.05)
