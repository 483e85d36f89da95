"""An on-board survey photographs by distance, as QGroundControl's surveys do (issue 17).

The planner's fly-through lines (``camera_trigger`` N at a line's start, 0 at its end) become
DO_SET_CAM_TRIGG_DIST items after the line's waypoints, and a ``takepic`` after a waypoint a
DO_DIGICAM_CONTROL after it: no item makes the vehicle stop for a picture. The mission's photo
count is what the autopilot reported (CAMERA_FEEDBACK), and equals the pictures the simulated
camera took. Before, every picture was a zero-second loiter (a stop) and a line's trigger could
not be flown on board at all.
"""

from __future__ import annotations

import asyncio
import itertools

import pytest

from dronefleet.drone.app import DroneApp
from dronefleet.drone.config import DroneConfig
from dronefleet.drone.fc import mavlink as mavlink_fc
from dronefleet.experiments.fleets import free_udp_port
from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.codec import decode_object
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.sim.mavlink import MavlinkSimServer
from dronefleet.sim.world import SimWorld
from support.brokers import mosquitto

pytestmark = pytest.mark.integration

HOME = LLA(40.63, -8.659, 10.0)


def survey_steps() -> list[dict]:
    def at(n: float, e: float) -> dict:
        p = ned_to_lla(NED(n, e), HOME)
        return {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": 10}

    wait = {"command": "wait_for_flight"}
    return [
        {"command": "arm"},
        {"command": "takeoff", "value": 10},
        at(20, 0),
        wait,
        {"command": "camera_trigger", "value": 12},  # pictures at 20, 32, 44, 56, 68 m
        at(70, 0),
        wait,
        {"command": "camera_trigger", "value": 0},
        at(70, 30),
        wait,
        {"command": "takepic"},  # one more, flown through
        at(40, 30),
        wait,
        {"command": "land"},
    ]


async def test_an_onboard_survey_photographs_by_distance_and_counts_what_the_autopilot_took(
    tmp_path,
):
    world = SimWorld(speedup=20)
    server = MavlinkSimServer(world)
    endpoint = server.add_vehicle(HOME, port=free_udp_port())
    copter = endpoint.copter
    pictures: list[NED] = []
    captured = copter.events.captured

    def record(info: dict) -> None:
        pictures.append(lla_to_ned(LLA(info["lat"], info["lon"], HOME.alt_m), HOME))
        captured(info)

    copter.events.captured = record  # type: ignore[method-assign]
    received: list[dict] = []
    steps = survey_steps()
    async with server:
        with mosquitto(tmp_path) as url:
            fc = await mavlink_fc.open_flight_controller(f"udpout:127.0.0.1:{endpoint.port}")
            sensors, camera = mavlink_fc.payload(fc)
            app = DroneApp(DroneConfig(drone_id="QUAD_S"), fc, url, sensors=sensors, camera=camera)
            await app.start()
            observer = BrokerClient(url, "observer-survey")
            await observer.start()
            try:

                async def on_progress(_topic: str, payload: bytes) -> None:
                    received.append(decode_object(payload))

                await observer.subscribe("QUAD_S/mission/out", on_progress)
                request = {"mission_id": "M-survey", "steps": steps, "onboard": True}
                await observer.publish("QUAD_S/mission/in", request)
                async with asyncio.timeout(60):
                    while not any(m["event"] in ("completed", "failed") for m in received):
                        await asyncio.sleep(0.05)
                uploaded = await fc.mission.download()
            finally:
                await observer.stop()
                await app.stop()
    end = received[-1]
    assert end["event"] == "completed", received
    commands = [item.command for item in uploaded]
    assert mav.MAV_CMD_NAV_LOITER_TIME not in commands  # no stop for any picture
    assert commands.count(mav.MAV_CMD_DO_SET_CAM_TRIGG_DIST) == 2
    # Five along the line (every 12 m from where 20 m was reached, within WPNAV_RADIUS), one at
    # (70, 30); the autopilot's count is the mission's.
    assert len(pictures) == 6, pictures
    line = [p.n for p in pictures[:5]]
    assert all(abs(p.e) < 1.0 for p in pictures[:5])
    assert [b - a for a, b in itertools.pairwise(line)] == pytest.approx([12] * 4, abs=1.0)
    assert (pictures[5] - NED(70, 30)).horizontal_m < 2.5
    assert end["result"] == {"on_board": True, "photos": 6}
    done = [m["step_index"] for m in received if m["event"] == "step"]
    assert done == list(range(len(steps))), received
