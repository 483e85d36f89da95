"""A fleet set up as the README's Security section says flies a mission (issue 12, must-show 1).

Every step is the project's own command line: ``credentials add-ground`` / ``add-drone`` into
the ground's state, ``broker-config`` for the ground's Mosquitto (password and ACL files),
``bridge-config --listener --local-dir`` for the drone's own Mosquitto, bridged to the ground's
with the drone's credentials. Both brokers refuse anonymous clients; the drone and the ground
log in with passwords read from 0600 files. A mission sent over REST is flown to the end.
"""

from __future__ import annotations

import getpass
import os
import secrets
import subprocess
import time
from pathlib import Path

import httpx
import paho.mqtt.publish as publish
import pytest

from dronefleet.messaging.embedded import free_port
from support.brokers import MOSQUITTO, wait_port
from support.ground_procs import dronefleet, process, wait_http, wait_online

pytestmark = pytest.mark.integration
HOME = (40.63, -8.659)


def cli(*args: str) -> str:
    return subprocess.run(dronefleet(*args), check=True, capture_output=True, text=True).stdout


def broker_process(conf: str, tmp: Path, name: str, port: int):
    """A Mosquitto with exactly the configuration the project wrote (plus where to log)."""
    user = "user root\n" if os.geteuid() == 0 else ""  # root: keep reading the 0600 files
    path = tmp / f"{name}.conf"
    path.write_text(conf + f"\npersistence false\n{user}log_dest file {tmp}/{name}.log\n")
    return process([MOSQUITTO, "-c", str(path)], tmp / f"{name}.out"), port


def test_a_fleet_with_credentials_everywhere_flies_a_mission_and_refuses_strangers(tmp_path):
    state = tmp_path / "ground.db"
    cli("credentials", "add-ground", "ground", "--state", str(state),
        "--password-file", str(tmp_path / "ground.secret"))  # fmt: skip
    cli("credentials", "add-drone", "QUAD_S", "--state", str(state),
        "--password-file", str(tmp_path / "QUAD_S.secret"))  # fmt: skip
    ground_port, drone_port, http_port = free_port(), free_port(), free_port()
    me = getpass.getuser()  # both Mosquittos run as us (user root below), not as mosquitto
    cli("broker-config", "--state", str(state), "--out", str(tmp_path / "ground-broker"),
        "--listener", f"127.0.0.1:{ground_port}", "--owner", me)  # fmt: skip
    drone_conf = cli(
        "bridge-config", "--drone-id", "QUAD_S", "--ground", f"127.0.0.1:{ground_port}",
        "--username", "QUAD_S", "--password-file", str(tmp_path / "QUAD_S.secret"),
        "--listener", f"127.0.0.1:{drone_port}", "--local-dir", str(tmp_path / "drone-broker"),
        "--owner", me,
    )  # fmt: skip
    ground_conf = (tmp_path / "ground-broker" / "dronefleet.conf").read_text()
    token = secrets.token_urlsafe(16)
    ground_args = dronefleet(
        "ground", "--broker", f"mqtt://ground@127.0.0.1:{ground_port}",
        "--broker-password-file", str(tmp_path / "ground.secret"), "--state", str(state),
        "--store", f"sqlite:///{tmp_path}/telemetry.db", "--http", f"127.0.0.1:{http_port}",
        f"--token={token}",
    )  # fmt: skip
    drone_args = dronefleet(
        "drone", "--id", "QUAD_S", "--broker", f"mqtt://QUAD_S@127.0.0.1:{drone_port}",
        "--broker-password-file", str(tmp_path / "QUAD_S.secret"), "--fc", "sim",
        "--home", f"{HOME[0]},{HOME[1]},10", "--speedup", "10",
    )  # fmt: skip
    ground_broker, _ = broker_process(ground_conf, tmp_path, "ground-broker", ground_port)
    drone_broker, _ = broker_process(drone_conf, tmp_path, "drone-broker", drone_port)
    with ground_broker, drone_broker:
        wait_port("127.0.0.1", ground_port)
        wait_port("127.0.0.1", drone_port)
        with (
            process(ground_args, tmp_path / "ground.log"),
            process(drone_args, tmp_path / "drone.log"),
            httpx.Client(base_url=f"http://127.0.0.1:{http_port}",
                         headers={"Authorization": f"Bearer {token}"}, timeout=30) as api,
        ):  # fmt: skip
            wait_http(str(api.base_url), log=tmp_path / "ground.log")
            wait_online(api, "QUAD_S")
            for port in (ground_port, drone_port):  # a stranger on either broker
                with pytest.raises(Exception, match=r"(?i)not authori[sz]ed|refused"):
                    publish.single("QUAD_S/control/in", b'{"command":"arm"}',
                                   hostname="127.0.0.1", port=port)  # fmt: skip
            steps: list[dict] = [{"command": "arm"}, {"command": "takeoff", "value": 10}]
            for i in range(3):
                steps += [
                    {"command": "navigate", "lat": HOME[0] + 0.0002 * (i + 1), "lon": HOME[1],
                     "altitude_delta": 10},
                    {"command": "wait_for_flight"},
                ]  # fmt: skip
            spec = {"name": "secured", "drones": ["QUAD_S"], "steps": [*steps, {"command": "land"}]}
            made = api.post("/api/v1/missions", params={"start": "true"}, json=spec)
            assert made.status_code == 201, made.text
            mission_id = made.json()["mission_id"]
            deadline = time.monotonic() + 120
            while (detail := api.get(f"/api/v1/missions/{mission_id}").json())["state"] in (
                "planned", "running",
            ):  # fmt: skip
                assert time.monotonic() < deadline, detail
                time.sleep(0.5)
    assert detail["state"] == "completed", detail.get("error")
    assert detail["steps_done"] == len(detail["work"])
    secrets_on_disk = [
        tmp_path / "ground-broker" / "passwd", tmp_path / "ground-broker" / "acl",
        tmp_path / "drone-broker" / "passwords", tmp_path / "drone-broker" / "acl",
        tmp_path / "ground.secret", tmp_path / "QUAD_S.secret", state,
    ]  # fmt: skip
    assert {p.stat().st_mode & 0o777 for p in secrets_on_disk} == {0o600}
