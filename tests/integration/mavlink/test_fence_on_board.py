"""A mission's geofence and rally points go on board the MAVLink autopilot before it flies
(issue 14): real bytes over loopback UDP to the simulated ArduPilot Copter, which keeps them as
ArduPilot does (sim/mavlink/transfer.py) and whose parameters the drone sets.

The drone (DroneApp on the MAVLink backend) gets a mission with an inclusion polygon, an exclusion
zone, a ceiling and two rally points: the autopilot holds the fence vertices
(MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION/EXCLUSION with each polygon's size), the rally points
(MAV_CMD_NAV_RALLY_POINT), FENCE_TYPE 5, FENCE_ALT_MAX and FENCE_ENABLE 1 before the first step,
and the mission flies to the end. A next mission without them clears them. An autopilot that
keeps other items than were sent fails the mission before it flies, with the reason.
"""

from __future__ import annotations

import pytest

from dronefleet.drone.app import DroneApp
from dronefleet.drone.config import DroneConfig
from dronefleet.drone.fc import mavlink as mavlink_fc
from dronefleet.experiments.fleets import free_udp_port
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import NED
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.sim.mavlink import MavlinkSimServer
from dronefleet.sim.mavlink.transfer import FENCE, RALLY
from dronefleet.sim.world import SimWorld
from support.drones import Operator

from .conftest import HOME

pytestmark = pytest.mark.integration
INCLUSION = mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
EXCLUSION = mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION


def box(n0: float, e0: float, n1: float, e1: float) -> list[list[float]]:
    corners = [(n0, e0), (n0, e1), (n1, e1), (n1, e0)]
    return [[p.lat, p.lon] for p in (ned_to_lla(NED(n, e), HOME) for n, e in corners)]


def rally(n: float, e: float, alt_m: float) -> dict:
    p = ned_to_lla(NED(n, e), HOME)
    return {"lat": p.lat, "lon": p.lon, "alt_m": alt_m}


def short_flight() -> list[dict]:
    wp = ned_to_lla(NED(30, 0), HOME)
    return [
        {"command": "arm"}, {"command": "takeoff", "value": 10}, {"command": "wait_for_flight"},
        {"command": "navigate", "lat": wp.lat, "lon": wp.lon, "altitude_delta": 10},
        {"command": "wait_for_flight"}, {"command": "land"}, {"command": "wait_for_flight"},
    ]  # fmt: skip


FENCE_SPEC = {
    "inclusion": box(-50, -50, 100, 50),
    "exclusions": [box(60, 20, 70, 30)],
    "ceiling_m": 40,
}
RALLY_SPEC = [rally(40, -20, 15), rally(80, 0, 12)]


def events(op: Operator, mission_id: str, kind: str) -> list[dict]:
    return [p for p in op.progress(mission_id) if p["event"] == kind]


async def drone_on_sim(embedded_broker, op: Operator, server: MavlinkSimServer, port: int):
    fc = await mavlink_fc.open_flight_controller(f"udpout:127.0.0.1:{port}")
    sensors, _camera = mavlink_fc.payload(fc)
    app = DroneApp(DroneConfig(drone_id="FENCED"), fc, embedded_broker, sensors=sensors)
    await app.start()
    return app


async def test_the_fence_and_rally_points_are_on_board_before_the_mission_flies(embedded_broker):
    world = SimWorld(speedup=10)
    server = MavlinkSimServer(world)
    endpoint = server.add_vehicle(HOME, port=free_udp_port())
    copter, transfer = endpoint.copter, endpoint.transfer
    on_board_at_first_step: list[tuple[int, int, float]] = []
    async with server, Operator(embedded_broker) as op:
        app = await drone_on_sim(embedded_broker, op, server, endpoint.port)
        try:
            await op.send_mission(
                "FENCED", mission_id="fe1", steps=short_flight(), fence=FENCE_SPEC,
                rally=RALLY_SPEC,
            )  # fmt: skip

            def first_step_seen():
                if events(op, "fe1", "step") and not on_board_at_first_step:
                    on_board_at_first_step.append(
                        (len(transfer.stored[FENCE]), len(transfer.stored[RALLY]),
                         copter.params.get("FENCE_ENABLE"))
                    )  # fmt: skip
                return events(op, "fe1", "completed") or events(op, "fe1", "failed")

            (end,) = await op.wait_for(first_step_seen, timeout_s=90)
            assert end["event"] == "completed", end
            fence, points = transfer.stored[FENCE], transfer.stored[RALLY]
            params = {
                n: copter.params.get(n)
                for n in (
                    "FENCE_ENABLE",
                    "FENCE_TYPE",
                    "FENCE_ALT_MAX",
                    "FENCE_TOTAL",
                    "RALLY_TOTAL",
                )
            }

            # A mission without them clears what this drone put there.
            await op.send_mission("FENCED", mission_id="fe2", steps=short_flight())
            (end,) = await op.wait_for(
                lambda: events(op, "fe2", "completed") or events(op, "fe2", "failed"), timeout_s=90
            )
            assert end["event"] == "completed", end  # a failure says why, not a timeout
            cleared = (len(transfer.stored[FENCE]), len(transfer.stored[RALLY]),
                       copter.params.get("FENCE_ENABLE"))  # fmt: skip
        finally:
            await app.stop()
            await app.fc.close()

    assert on_board_at_first_step == [(8, 2, 1)]
    assert [(i.command, i.param1) for i in fence] == [(INCLUSION, 4)] * 4 + [(EXCLUSION, 4)] * 4
    sent = [*FENCE_SPEC["inclusion"], *FENCE_SPEC["exclusions"][0]]
    assert [(i.x, i.y) for i in fence] == [(round(a * 1e7), round(b * 1e7)) for a, b in sent]
    assert [(i.command, i.x, i.y, i.z) for i in points] == [
        (mav.MAV_CMD_NAV_RALLY_POINT, round(p["lat"] * 1e7), round(p["lon"] * 1e7), p["alt_m"])
        for p in RALLY_SPEC
    ]
    assert params == {"FENCE_ENABLE": 1, "FENCE_TYPE": 5, "FENCE_ALT_MAX": 40, "FENCE_TOTAL": 8,
                      "RALLY_TOTAL": 2}  # fmt: skip
    assert cleared == (0, 0, 0)


async def test_a_fence_the_autopilot_does_not_keep_as_sent_fails_the_mission(embedded_broker):
    world = SimWorld(speedup=10)
    server = MavlinkSimServer(world)
    endpoint = server.add_vehicle(HOME, port=free_udp_port())
    transfer = endpoint.transfer
    store = transfer._store

    def keep_one_less(mission_type: int, items: list) -> None:  # a faulty autopilot
        store(mission_type, items[:-1] if mission_type == FENCE else items)

    transfer._store = keep_one_less
    async with server, Operator(embedded_broker) as op:
        app = await drone_on_sim(embedded_broker, op, server, endpoint.port)
        try:
            await op.send_mission("FENCED", mission_id="fe3", steps=short_flight(),
                                  fence=FENCE_SPEC)  # fmt: skip
            (failed,) = await op.wait_for(lambda: events(op, "fe3", "failed"), timeout_s=60)
            flew = endpoint.copter.vehicle.armed or events(op, "fe3", "step")
        finally:
            await app.stop()
            await app.fc.close()
    assert "geofence upload not kept as sent: the autopilot kept 7 of 8 items" in failed["error"]
    assert failed["error"].startswith("not flown")
    assert not flew
