"""A second MAVLink ground station takes the vehicle mid-mission: the mission pauses, then resumes
on command (issue 10, must-show 3).

The drone (DroneApp on the MAVLink backend) flies a step-by-step mission on a simulated ArduPilot
Copter over loopback UDP; a plain pymavlink client, as MAVProxy or QGroundControl would, switches
the vehicle to LOITER (an operator's hold) or RTL (what ArduPilot's own failsafes choose). The
mission is reported paused within one vehicle second of the switch, nothing flies it on while the
other station has it, and a ``resume`` on ``mission/in`` flies every step left to the end.
"""

from __future__ import annotations

import asyncio

import pytest
from pymavlink import mavutil

from dronefleet.drone.app import DroneApp
from dronefleet.drone.config import DroneConfig
from dronefleet.drone.fc import mavlink as mavlink_fc
from dronefleet.drone.takeover import SOMEONE_ELSE
from dronefleet.experiments.fleets import free_udp_port
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import NED
from dronefleet.protocols.mavlink.modes import CopterMode
from dronefleet.sim.mavlink import MavlinkSimServer
from dronefleet.sim.world import SimWorld
from support.drones import Operator

from .conftest import HOME

pytestmark = pytest.mark.integration
ACCEPTED = mavutil.mavlink.MAV_RESULT_ACCEPTED


def line(waypoints: int, spacing_m: float = 40.0) -> list[dict]:
    steps: list[dict] = [{"command": "arm"}, {"command": "takeoff", "value": 10}]
    for i in range(waypoints):
        wp = ned_to_lla(NED(spacing_m * (i + 1), 0), HOME)
        steps += [
            {"command": "navigate", "lat": wp.lat, "lon": wp.lon, "altitude_delta": 10},
            {"command": "wait_for_flight"},
        ]
    return [*steps, {"command": "land"}, {"command": "wait_for_flight"}]


def switch_mode(port: int, mode: CopterMode) -> int:
    """Another ground station: connects, and sets ``mode``; the COMMAND_ACK's result."""
    conn = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=250)
    try:
        beat = None
        for _ in range(40):
            conn.mav.heartbeat_send(
                mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0
            )
            beat = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.25)
            if beat is not None:
                break
        assert beat is not None, "the vehicle never answered the second station"
        conn.mav.command_long_send(
            beat.get_srcSystem(), beat.get_srcComponent(),
            mavutil.mavlink.MAV_CMD_DO_SET_MODE, 0,
            mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, int(mode), 0, 0, 0, 0, 0,
        )  # fmt: skip
        ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=5)
        assert ack is not None, "no COMMAND_ACK for the mode change"
        return int(ack.result)
    finally:
        conn.close()


def events(op: Operator, kind: str) -> list[dict]:
    return [p for p in op.progress("tk") if p["event"] == kind]


@pytest.mark.parametrize("mode", [CopterMode.LOITER, CopterMode.RTL], ids=["loiter", "rtl"])
async def test_another_station_takes_the_vehicle_and_the_mission_pauses_then_resumes(
    mode, embedded_broker
):
    world = SimWorld(speedup=10)
    server = MavlinkSimServer(world)
    endpoint = server.add_vehicle(HOME, port=free_udp_port())
    copter = endpoint.copter
    steps = line(5)
    async with server, Operator(embedded_broker) as op:
        fc = await mavlink_fc.open_flight_controller(f"udpout:127.0.0.1:{endpoint.port}")
        sensors, _camera = mavlink_fc.payload(fc)
        app = DroneApp(DroneConfig(drone_id="QUAD_K"), fc, embedded_broker, sensors=sensors)
        await app.start()
        try:
            await op.send_mission("QUAD_K", mission_id="tk", steps=steps)
            await op.wait_for(lambda: len(events(op, "step")) >= 5, timeout_s=60)
            switched: list[float] = []  # the autopilot's own time of the switch
            set_mode = copter.set_mode

            def set_and_note(number: int) -> None:
                set_mode(number)
                switched.append(copter.boot_ms() / 1000)

            copter.set_mode = set_and_note
            assert await asyncio.to_thread(switch_mode, endpoint.port, mode) == ACCEPTED
            (paused,) = await op.wait_for(lambda: events(op, "paused"), timeout_s=20)
            # The drone's clock is its estimate of the autopilot's (time_boot_ms, then the wall
            # time since at the measured speed-up): a few hundredths either way.
            assert -0.2 <= paused["vehicle_time_s"] - switched[-1] <= 1.0, (paused, switched)
            assert paused["result"] == {"mode": mode.name, "by": SOMEONE_ELSE}, paused
            steps_then = len(events(op, "step"))
            await fc.clock.sleep(5.0)
            assert len(events(op, "step")) == steps_then  # the other station has it
            assert copter.mode is mode  # not switched back to GUIDED by the drone
            assert fc.state().in_air
            await op.send_mission("QUAD_K", mission_id="tk", action="resume")
            await op.wait_for(lambda: events(op, "resumed"), timeout_s=20)
            await op.wait_for(lambda: events(op, "completed"), timeout_s=120)
        finally:
            await app.stop()
    done = sorted({p["step_index"] for p in events(op, "step")})
    assert done == list(range(len(steps)))
    assert not events(op, "failed")
