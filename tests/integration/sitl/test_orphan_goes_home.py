"""A vehicle whose drone software dies goes home by itself, on ArduPilot SITL (issue 26, item 3).

Measured before: a drone process SIGKILLed while its copter hovered in GUIDED left it hovering
until its battery read 0 %. Now the drone turns ArduPilot's GCS failsafe on at connect
(FS_GCS_ENABLE 1, RTL; FS_OPTIONS bit 3) and heartbeats it every second of its clock (SITL runs
10 times faster here): alive, 20 wall s (200 vehicle s) of hovering never trip it; killed, the
copter announces "GCS Failsafe" and switches to RTL FS_GCS_TIMEOUT (5 vehicle s) later. Watched
from SITL's second port by a station that is not its GCS (system id 251, not SYSID_MYGCS).
"""

from __future__ import annotations

import contextlib
import time

import pytest
from pymavlink import mavutil

from support.processes import dronefleet, process, stop
from support.sitl import SITL_SPEEDUP, sitl_vehicle

pytestmark = [pytest.mark.integration, pytest.mark.sitl]

GUIDED, RTL = 4, 6


def test_a_killed_drones_copter_returns_home_and_a_live_one_never_fails_safe(
    ground, sitl_binary, tmp_path
):
    with contextlib.ExitStack() as stack:
        default = {"FS_GCS_TIMEOUT": 5.0}  # ArduPilot's own, not the suite's scaled one
        vehicle = stack.enter_context(sitl_vehicle(sitl_binary, tmp_path / "ORPH", default))
        cmd = dronefleet(
            "-v", "drone", "--id", "ORPH", "--broker", ground.broker, "--fc", "mavlink",
            "--fc-url", vehicle.url, "--heartbeat-s", "1",
        )  # fmt: skip
        drone = stack.enter_context(process(cmd, tmp_path / "ORPH.log"))
        ground.wait_online("ORPH")
        beat = ground.drone("ORPH")
        assert beat["link_failsafe"] == {"action": "rtl", "timeout_s": 5.0, "set_by_drone": True}
        for command, body in (("arm", None), ("takeoff", {"value": 10})):
            answer = ground.api("POST", f"/api/v1/drones/ORPH/commands/{command}", json=body)
            assert answer.status_code == 200, answer.text
        watch = mavutil.mavlink_connection(vehicle.second_url, source_system=251)
        stack.callback(watch.close)
        assert watch.wait_heartbeat(timeout=10) is not None
        # Heard once, its port is active and gets STATUSTEXTs too (a station ArduPilot never
        # heard from gets streams, not texts); as 251, not SYSID_MYGCS: it keeps no failsafe off.
        m = mavutil.mavlink
        watch.mav.heartbeat_send(m.MAV_TYPE_GCS, m.MAV_AUTOPILOT_INVALID, 0, 0, 0)

        def modes(for_s: float) -> tuple[set[int], list[str]]:
            seen, texts = set(), []
            end = time.monotonic() + for_s
            while time.monotonic() < end:
                msg = watch.recv_match(type=["HEARTBEAT", "STATUSTEXT"], blocking=True, timeout=1)
                if msg is None:
                    continue
                if msg.get_type() == "STATUSTEXT":
                    texts.append(msg.text)
                elif msg.get_srcSystem() == watch.target_system and msg.type != 6:  # not a GCS
                    seen.add(msg.custom_mode)
            return seen, texts

        modes(8.0)  # the take-off
        alive, texts = modes(20.0)  # hovering, 200 vehicle s
        assert alive == {GUIDED}, (alive, texts)
        assert not [t for t in texts if "GCS Failsafe" in t], texts

        stop(drone, sig_kill=True)  # the drone software dies; the copter hovers
        killed_at = time.monotonic()
        rtl_after_s = None
        texts = []
        while time.monotonic() - killed_at < 10.0 and rtl_after_s is None:
            seen, more = modes(0.1)
            texts += more
            if RTL in seen:
                rtl_after_s = time.monotonic() - killed_at
        texts += modes(3.0)[1]  # what it says about it
    print(f"RTL {rtl_after_s} wall s after the kill (x{SITL_SPEEDUP} vehicle s); said {texts}")
    assert rtl_after_s is not None, texts
    assert rtl_after_s * SITL_SPEEDUP < 5.0 + 10.0  # FS_GCS_TIMEOUT, and a heartbeat or so
    assert any("GCS Failsafe" in t for t in texts), texts
