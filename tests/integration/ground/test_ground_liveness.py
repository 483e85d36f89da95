"""A drone whose process dies is ``lost`` within 3 heartbeat intervals and ``online`` again when it
comes back; the ground services, restarted, still know the fleet and the audit log.
"""

from __future__ import annotations

import secrets
import time

import httpx
import pytest

from dronefleet.messaging.embedded import free_port
from support.brokers import mosquitto
from support.ground_procs import drone_cmd, ground_cmd, process, stop, wait_http, wait_online

pytestmark = pytest.mark.integration

SPEEDUP = 5.0  # 3 intervals = 3 s of wall time, above the 2 s floor of fleet.MIN_LOST_AFTER_S
INTERVAL_WALL_S = 5.0 / SPEEDUP  # 5 s heartbeats in vehicle time


def wait_status(api: httpx.Client, drone_id: str, status: str, timeout_s: float) -> float:
    start = time.monotonic()
    while time.monotonic() - start < timeout_s:
        r = api.get(f"/api/v1/drones/{drone_id}")
        if r.status_code == 200 and r.json()["status"] == status:
            return time.monotonic() - start
        time.sleep(0.05)
    raise AssertionError(f"{drone_id} not {status} within {timeout_s} s")


def test_a_killed_drone_is_lost_then_back_and_the_ground_remembers(tmp_path):
    drone_id = f"LIVE_{secrets.token_hex(3)}"
    token = secrets.token_urlsafe(16)
    port = free_port()
    with mosquitto(tmp_path) as broker:
        url = f"http://127.0.0.1:{port}"
        api = httpx.Client(base_url=url, headers={"Authorization": f"Bearer {token}"}, timeout=30)
        ground = ground_cmd(broker.full(), tmp_path, port, token)
        with process(ground, tmp_path / "ground.log") as ground_proc:
            wait_http(url)
            with process(drone_cmd(drone_id, broker.full(), SPEEDUP), tmp_path / "d1.log") as d:
                wait_online(api, drone_id)
                time.sleep(3 * INTERVAL_WALL_S)  # let the Identifier learn the wall interval
                assert api.post(f"/api/v1/drones/{drone_id}/commands/arm").status_code == 200
                stop(d, sig_kill=True)
                # The last heartbeat came at most one interval before the kill.
                took = wait_status(api, drone_id, "lost", timeout_s=10)
                assert took <= 3 * INTERVAL_WALL_S + 0.3, took
            refused = api.post(f"/api/v1/drones/{drone_id}/commands/disarm")
            assert refused.status_code == 409 and refused.json()["last_seen"]
            with process(drone_cmd(drone_id, broker.full(), SPEEDUP), tmp_path / "d2.log"):
                wait_status(api, drone_id, "online", timeout_s=20)
                stop(ground_proc)
                with process(ground, tmp_path / "ground2.log"):
                    wait_http(url)
                    fleet = api.get("/api/v1/drones").json()
                    assert [d["drone_id"] for d in fleet] == [drone_id]
                    audit = api.get("/api/v1/audit", params={"drone": drone_id}).json()
                    assert [(a["command"], a["status"]) for a in audit] == [
                        ("disarm", 409),
                        ("arm", 200),
                    ]
                    wait_status(api, drone_id, "online", timeout_s=10)
                    assert api.post(f"/api/v1/drones/{drone_id}/commands/disarm").status_code == 200
        api.close()
