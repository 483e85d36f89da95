"""ArduPilot Copter SITL takes a mission's geofence and rally points (issue 14).

A mission with an inclusion polygon, an exclusion zone, a ceiling and two rally points is sent
through the REST API; the drone puts them on board before flying, and the mission completes with
ArduPilot's fence enabled. Another ground station then reads from the autopilot, over its second
serial port, what ArduPilot kept: the fence vertices and rally points as sent, FENCE_ENABLE 1,
FENCE_TYPE 5 (polygon and altitude), FENCE_ALT_MAX the ceiling.
"""

from __future__ import annotations

import pytest
from pymavlink import mavutil

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED

pytestmark = [pytest.mark.integration, pytest.mark.sitl]
m = mavutil.mavlink


def home_of(drone: dict) -> LLA:
    h = drone["home"]
    return LLA(h["lat"], h["lon"], h["alt_m"])


def download(conn, mission_type: int) -> list:
    """The items of ``mission_type`` on board, as a ground station downloads them."""
    for _ in range(5):
        conn.mav.mission_request_list_send(conn.target_system, 1, mission_type)
        count = conn.recv_match(type="MISSION_COUNT", blocking=True, timeout=2)
        if count is not None and count.mission_type == mission_type:
            break
    else:
        raise TimeoutError(f"no MISSION_COUNT for mission type {mission_type}")
    items = []
    for seq in range(count.count):
        conn.mav.mission_request_int_send(conn.target_system, 1, seq, mission_type)
        item = conn.recv_match(type="MISSION_ITEM_INT", blocking=True, timeout=2)
        assert item is not None and item.seq == seq, f"item {seq} of type {mission_type}"
        items.append(item)
    conn.mav.mission_ack_send(conn.target_system, 1, m.MAV_MISSION_ACCEPTED, mission_type)
    return items


def param(conn, name: str) -> float:
    conn.mav.param_request_read_send(conn.target_system, 1, name.encode(), -1)
    while True:
        answer = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=3)
        assert answer is not None, f"no PARAM_VALUE for {name}"
        if answer.param_id.rstrip("\x00") == name:
            return float(answer.param_value)


def test_ardupilot_keeps_the_missions_fence_and_rally_points(ground, fly):
    vehicle = fly("SITL_1")
    home = home_of(ground.drone("SITL_1"))

    def at(n: float, e: float) -> list[float]:
        p = ned_to_lla(NED(n, e), home)
        return [p.lat, p.lon]

    inclusion = [at(-60, -60), at(-60, 60), at(120, 60), at(120, -60)]
    exclusion = [at(70, 20), at(70, 40), at(90, 40), at(90, 20)]
    rally = [{"lat": at(50, -40)[0], "lon": at(50, -40)[1], "alt_m": 15},
             {"lat": at(100, 0)[0], "lon": at(100, 0)[1], "alt_m": 20}]  # fmt: skip
    wp = at(60, 0)
    spec = {
        "name": "fenced",
        "drones": ["SITL_1"],
        "steps": [
            {"command": "navigate", "lat": wp[0], "lon": wp[1], "altitude_delta": 20},
            {"command": "wait_for_flight"},
        ],
        "options": {
            "geofence": {"inclusion": inclusion, "exclusions": [exclusion], "ceiling_m": 50},
            "rally_points": rally,
        },
    }
    mission = ground.run_mission(spec)
    assert mission["state"] == "completed", mission.get("error")

    conn = mavutil.mavlink_connection(vehicle.second_url, source_system=252)
    try:
        conn.wait_heartbeat(timeout=10)
        fence = download(conn, m.MAV_MISSION_TYPE_FENCE)
        points = download(conn, m.MAV_MISSION_TYPE_RALLY)
        params = {n: param(conn, n) for n in ("FENCE_ENABLE", "FENCE_TYPE", "FENCE_ALT_MAX")}
    finally:
        conn.close()
    inc, exc = (
        m.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
        m.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
    )
    assert [(i.command, round(i.param1)) for i in fence] == [(inc, 4)] * 4 + [(exc, 4)] * 4
    sent = [*inclusion, *exclusion]
    assert [(i.x, i.y) for i in fence] == [(round(a * 1e7), round(b * 1e7)) for a, b in sent]
    assert [(i.command, i.x, i.y, round(i.z)) for i in points] == [
        (m.MAV_CMD_NAV_RALLY_POINT, round(p["lat"] * 1e7), round(p["lon"] * 1e7), p["alt_m"])
        for p in rally
    ]
    assert params == {"FENCE_ENABLE": 1, "FENCE_TYPE": 5, "FENCE_ALT_MAX": 50}
