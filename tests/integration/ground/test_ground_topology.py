"""The seed's topology end to end (4.3.2): drone Mosquitto bridged to a ground broker.

Real processes: a Mosquitto per drone, configured by ``dronefleet bridge-config`` (Listing 4.3);
a ground broker (a Mosquitto of our own, or RabbitMQ's MQTT adapter as in the seed); a
``dronefleet drone`` process and a ``dronefleet ground`` process. A REST ``arm`` and ``takeoff``
reach the drone through the bridge and the drone's answers come back the same way.
"""

from __future__ import annotations

import secrets
import subprocess
from pathlib import Path

import httpx
import pytest

from dronefleet.messaging.embedded import free_port
from dronefleet.messaging.url import BrokerUrl
from support.brokers import mosquitto
from support.ground_procs import (
    drone_cmd,
    dronefleet,
    ground_cmd,
    process,
    rabbit_mqtt_or_skip,
    wait_http,
    wait_online,
)

pytestmark = pytest.mark.integration


def bridge_conf(drone_id: str, ground: BrokerUrl, tmp: Path) -> str:
    args = ["bridge-config", "--drone-id", drone_id, "--ground", f"{ground.host}:{ground.port}"]
    if ground.username:
        secret = tmp / "bridge.secret"  # a password never goes on a command line (issue 12)
        secret.write_text(ground.password or "")
        args += ["--username", ground.username, "--password-file", str(secret)]
    return subprocess.run(dronefleet(*args), check=True, capture_output=True, text=True).stdout


def fly_through_bridge(tmp: Path, ground: BrokerUrl) -> None:
    drone_id = f"BRIDGED_{secrets.token_hex(3)}"
    token = secrets.token_urlsafe(16)
    port = free_port()
    conf = bridge_conf(drone_id, ground, tmp)
    assert f"topic {drone_id}/control/in in" in conf and "topic +/telemetry/out out" in conf
    with (
        mosquitto(tmp, extra_conf=conf) as internal,
        process(drone_cmd(drone_id, internal.full()), tmp / "drone.log"),
        process(ground_cmd(ground.full(), tmp, port, token), tmp / "ground.log"),
        httpx.Client(
            base_url=f"http://127.0.0.1:{port}",
            headers={"Authorization": f"Bearer {token}"},
            timeout=30,
        ) as api,
    ):
        wait_http(str(api.base_url), log=tmp / "ground.log")
        record = wait_online(api, drone_id)
        assert record["state"] == "disarmed"
        armed = api.post(f"/api/v1/drones/{drone_id}/commands/arm")
        assert armed.status_code == 200, armed.text
        assert armed.json()["ok"] and armed.json()["drone_id"] == drone_id
        took_off = api.post(f"/api/v1/drones/{drone_id}/commands/takeoff", json={"value": 10})
        assert took_off.status_code == 200, took_off.text
        assert took_off.json()["ok"]
        gear = api.get(f"/api/v1/drones/{drone_id}/gear")
        assert gear.status_code == 200 and gear.json()["specs"], gear.text
        audit = api.get("/api/v1/audit", params={"drone": drone_id}).json()
        assert [a["command"] for a in audit] == ["takeoff", "arm"]


def test_rest_commands_cross_a_mosquitto_bridge_to_a_ground_mosquitto(tmp_path):
    with mosquitto(tmp_path) as ground:
        fly_through_bridge(tmp_path, ground)


def test_rest_commands_cross_a_mosquitto_bridge_to_rabbitmq(tmp_path):
    host, port = rabbit_mqtt_or_skip()
    fly_through_bridge(tmp_path, BrokerUrl(host, port, "guest", "guest"))
