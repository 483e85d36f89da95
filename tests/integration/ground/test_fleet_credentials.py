"""The fleet's broker credentials end to end (issue 12): made by the CLI, kept hashed, enforced
by a real Mosquitto, used by real `dronefleet drone` and `dronefleet ground` processes.

`dronefleet credentials` writes each password to a 0600 file (never on a command line);
`dronefleet broker-config` writes the password and ACL files; the processes read their password
from `--broker-password-file`. The drone is identified and commanded through the REST API; a
stranger, and the drone's credentials used to command another drone, are refused.
"""

from __future__ import annotations

import getpass
import secrets
import stat
import subprocess

import httpx
import paho.mqtt.publish as publish
import pytest

from dronefleet.messaging.embedded import free_port
from support.brokers import mosquitto
from support.ground_procs import dronefleet, process, wait_http, wait_online

pytestmark = pytest.mark.integration


def cli(*args: str) -> str:
    done = subprocess.run(
        [*dronefleet(*args)], capture_output=True, text=True, timeout=60, check=False
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_generated_credentials_let_the_fleet_in_and_keep_strangers_out(tmp_path):
    state = tmp_path / "ground.db"
    cli("credentials", "add-ground", "ground", "--state", str(state),
        "--password-file", str(tmp_path / "ground.secret"))  # fmt: skip
    for drone in ("QUAD_1", "QUAD_2"):
        cli("credentials", "add-drone", drone, "--state", str(state),
            "--password-file", str(tmp_path / f"{drone}.secret"))  # fmt: skip
    out = tmp_path / "broker"
    # The test's Mosquitto runs as us (support/brokers.py: user root), not as mosquitto.
    cli("broker-config", "--state", str(state), "--out", str(out), "--owner", getpass.getuser())
    for name in ("passwd", "acl", "../ground.secret", "../QUAD_1.secret"):
        assert stat.S_IMODE((out / name).stat().st_mode) == 0o600, name
    secret = (tmp_path / "QUAD_1.secret").read_text().strip()
    assert secret.encode() not in state.read_bytes() and secret not in (out / "passwd").read_text()

    extra = f"password_file {out / 'passwd'}\nacl_file {out / 'acl'}\n"
    with mosquitto(tmp_path, extra, anonymous=False) as url:
        broker = f"mqtt://{{user}}@{url.host}:{url.port}"
        http_port, token = free_port(), secrets.token_urlsafe(16)
        ground = dronefleet(
            "ground", "--broker", broker.format(user="ground"),
            "--broker-password-file", str(tmp_path / "ground.secret"),
            "--store", f"sqlite:///{tmp_path}/t.db", "--state", str(state),
            "--http", f"127.0.0.1:{http_port}", f"--token={token}",
        )  # fmt: skip
        drone = dronefleet(
            "drone", "--id", "QUAD_1", "--broker", broker.format(user="QUAD_1"),
            "--broker-password-file", str(tmp_path / "QUAD_1.secret"), "--fc", "sim",
            "--home", "40.63,-8.659,10", "--speedup", "10",
        )  # fmt: skip
        assert all("secret" not in a or a.endswith(".secret") for a in [*ground, *drone])
        with process(ground, tmp_path / "ground.log"), process(drone, tmp_path / "drone.log"):
            base = f"http://127.0.0.1:{http_port}"
            wait_http(base, log=tmp_path / "ground.log")
            api = httpx.Client(base_url=base, headers={"Authorization": f"Bearer {token}"})
            wait_online(api, "QUAD_1")
            r = api.post("/api/v1/drones/QUAD_1/commands/arm", json={}, timeout=30)
            assert r.status_code == 200, r.text
            # A stranger cannot connect (per-drone rules: tests/integration/test_broker_rules.py).
            with pytest.raises(Exception, match=r"(?i)not authori[sz]ed|refused"):
                publish.single("QUAD_1/control/in", "{}", hostname=url.host, port=url.port)
