"""A plain pymavlink ground station, run as its own process by the tests: connects the way
MAVProxy does, downloads the parameters and the mission, switches to GUIDED, arms, takes off to
5 m and flies 20 m north with a position target. Prints one JSON line with what it saw.
Usage: ``python gcs_probe.py udpout:127.0.0.1:PORT``."""

from __future__ import annotations

import json
import sys
import time

from pymavlink import mavutil


def main(url: str) -> None:
    conn = mavutil.mavlink_connection(url, source_system=255)
    deadline = time.time() + 10
    beat = None
    while beat is None and time.time() < deadline:
        conn.mav.heartbeat_send(
            mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0
        )
        beat = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
    seen: dict = {"autopilot": beat.autopilot, "type": beat.type, "sysid": conn.target_system}
    conn.param_fetch_all()
    params: dict[str, float] = {}
    while time.time() < deadline:
        msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=1)
        if msg is None:
            break
        params[msg.param_id] = msg.param_value
        if len(params) == msg.param_count:
            break
    seen["params"] = params
    conn.waypoint_request_list_send()
    count = conn.recv_match(type="MISSION_COUNT", blocking=True, timeout=2)
    seen["mission_count"] = None if count is None else count.count
    conn.set_mode(conn.mode_mapping()["GUIDED"])
    conn.arducopter_arm()
    conn.motors_armed_wait()
    seen["armed_mode"] = conn.flightmode
    m = mavutil.mavlink
    conn.mav.command_long_send(
        conn.target_system, conn.target_component, m.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0, 5
    )
    seen["takeoff_ack"] = _ack(conn, m.MAV_CMD_NAV_TAKEOFF)
    seen["climbed_m"] = _wait_height(conn, 4.5, timeout_s=20)
    start = conn.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=2)
    north_lat = start.lat + round(20 / 111_320 * 1e7)
    conn.mav.set_position_target_global_int_send(
        0, conn.target_system, conn.target_component, m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        0b0000111111111000, north_lat, start.lon, 5, 0, 0, 0, 0, 0, 0, 0, 0,
    )  # fmt: skip
    seen["flew_north_m"] = _wait_north(conn, start.lat, 19.0, timeout_s=20)
    print(json.dumps(seen), flush=True)


def _ack(conn, command: int) -> int | None:
    deadline = time.time() + 5
    while time.time() < deadline:
        ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=1)
        if ack is not None and ack.command == command:
            return ack.result
    return None


def _wait_height(conn, height_m: float, timeout_s: float) -> float:
    deadline, best = time.time() + timeout_s, 0.0
    while time.time() < deadline and best < height_m:
        pos = conn.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=1)
        if pos is not None:
            best = max(best, pos.relative_alt / 1000)
    return best


def _wait_north(conn, lat0: int, metres: float, timeout_s: float) -> float:
    deadline, best = time.time() + timeout_s, 0.0
    while time.time() < deadline and best < metres:
        pos = conn.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=1)
        if pos is not None:
            best = max(best, (pos.lat - lat0) / 1e7 * 111_320)
    return best


if __name__ == "__main__":
    main(sys.argv[1])
