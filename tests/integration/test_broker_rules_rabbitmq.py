"""The fleet's broker rules on RabbitMQ, generated and loaded as an operator would (issue 12).

``dronefleet credentials add-drone`` / ``add-ground`` make the users, ``dronefleet broker-config
--broker rabbitmq`` writes the definitions file, ``rabbitmqctl import_definitions`` loads it into
a vhost of this test's own on the machine's RabbitMQ; clients speak MQTT to its adapter
(scripts/system-deps.sh puts it on 127.0.0.1:1884). A wrong password is refused; drone A cannot
publish to B's topics nor subscribe to B's ``control/in`` (RabbitMQ closes the connection); the
ground commands A and hears its telemetry; a client without credentials lands outside the
fleet's vhost and reaches no drone. The vhost and users are removed afterwards.
"""

from __future__ import annotations

import json
import secrets
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import paho.mqtt.client as mqtt
import pytest

from support.ground_procs import rabbit_mqtt_or_skip
from support.processes import dronefleet

pytestmark = pytest.mark.integration


class Client:
    """A paho client that records what it gets, its SUBACKs and how it was disconnected."""

    def __init__(self, port: int, user: str | None, password: str | None, client_id: str):
        self.got: list[tuple[str, bytes]] = []
        self.connected: list[int] = []
        self.dropped: list[int] = []
        self.mqtt = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=client_id)
        if user is not None:
            self.mqtt.username_pw_set(user, password)
        self.mqtt.on_message = lambda _c, _u, m: self.got.append((m.topic, m.payload))
        self.mqtt.on_connect = lambda _c, _u, _f, rc, _p: self.connected.append(rc.value)
        self.mqtt.on_disconnect = lambda _c, _u, _f, rc, _p: self.dropped.append(rc.value)
        self.mqtt.connect("127.0.0.1", port)
        self.mqtt.loop_start()
        wait(lambda: self.connected or self.dropped)

    def close(self) -> None:
        self.mqtt.loop_stop()
        self.mqtt.disconnect()


def wait(predicate, timeout_s: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.05)
    return False


@pytest.fixture
def fleet_vhost(tmp_path: Path) -> Iterator[tuple[dict[str, str], dict[str, tuple[str, str]], int]]:
    """A vhost with drones A and B and a ground user, from the generated definitions."""
    _host, port = rabbit_mqtt_or_skip()
    tag = secrets.token_hex(3).upper()
    names = {"a": f"RQA_{tag}", "b": f"RQB_{tag}", "ground": f"rqground-{tag.lower()}"}
    vhost = f"dronefleet-test-{tag.lower()}"
    state = tmp_path / "ground.db"
    for key, name in names.items():
        action = "add-ground" if key == "ground" else "add-drone"
        subprocess.run(
            dronefleet("credentials", action, name, "--state", str(state),
                       "--password-file", str(tmp_path / f"{key}.pw")),
            check=True, capture_output=True,
        )  # fmt: skip
    subprocess.run(
        dronefleet("broker-config", "--broker", "rabbitmq", "--vhost", vhost,
                   "--state", str(state), "--out", str(tmp_path)),
        check=True, capture_output=True,
    )  # fmt: skip
    definitions = tmp_path / "rabbitmq-definitions.json"
    assert definitions.stat().st_mode & 0o777 == 0o600
    assert "password" not in json.dumps(json.loads(definitions.read_text())["users"]).replace(
        "password_hash", ""
    )  # hashes only
    with open(definitions, "rb") as given:  # on stdin: the node cannot read a 0600 file
        subprocess.run(["rabbitmqctl", "import_definitions"], stdin=given, check=True,
                       capture_output=True, timeout=60)  # fmt: skip
    assert wait(lambda: vhost in _rabbitmqctl("list_vhosts"), 30)
    passwords = {k: (tmp_path / f"{k}.pw").read_text().strip() for k in names}
    try:
        # MQTT clients log in as VHOST:USER.
        yield names, {k: (f"{vhost}:{names[k]}", passwords[k]) for k in names}, port
    finally:
        _rabbitmqctl("delete_vhost", vhost)
        for name in names.values():
            _rabbitmqctl("delete_user", name)


def _rabbitmqctl(*args: str) -> str:
    done = subprocess.run(["rabbitmqctl", "-q", *args], capture_output=True, text=True, timeout=60)
    return done.stdout


def test_rabbitmq_rules_generated_by_the_project_hold(fleet_vhost) -> None:
    names, login, port = fleet_vhost
    a_user, b_user = names["a"], names["b"]
    clients: list[Client] = []

    def connect(who: str, client_id: str, password: str | None = None) -> Client:
        user, right = login[who]
        client = Client(port, user, password or right, client_id)
        clients.append(client)
        return client

    try:
        wrong = connect("a", f"{a_user}-bad", password="not-its-password")
        assert wrong.connected in ([134], [135]) or wrong.dropped, (wrong.connected, wrong.dropped)

        ground = connect("ground", "ground-test")
        b = connect("b", f"{b_user}-controller")
        a = connect("a", f"{a_user}-controller")
        assert ground.connected == a.connected == b.connected == [0]
        ground.mqtt.subscribe("+/telemetry/out", qos=1)
        a.mqtt.subscribe(f"{a_user}/control/in", qos=1)
        b.mqtt.subscribe(f"{b_user}/control/in", qos=1)
        time.sleep(0.5)

        ground.mqtt.publish(f"{a_user}/control/in", b'{"command":"arm"}', qos=1)
        assert wait(lambda: a.got), "the ground's command never reached drone A"
        a.mqtt.publish(f"{a_user}/telemetry/out", b"{}", qos=1)
        assert wait(lambda: ground.got), "drone A's telemetry never reached the ground"

        forger = connect("a", f"{a_user}-gear")
        forger.mqtt.publish(f"{b_user}/control/in", b'{"command":"takeoff"}', qos=1)
        assert wait(lambda: forger.dropped), "publishing to B's topic was not refused"
        spy = connect("a", f"{a_user}-logger")
        spy.mqtt.subscribe(f"{b_user}/control/in", qos=1)
        assert wait(lambda: spy.dropped), "subscribing to B's control/in was not refused"
        ground.mqtt.publish(f"{b_user}/control/in", b'{"command":"land"}', qos=1)
        assert wait(lambda: b.got) and not spy.got
        assert b.got == [(f"{b_user}/control/in", b'{"command":"land"}')]  # nothing forged

        stranger = Client(port, None, None, "stranger-1")  # no credentials at all
        clients.append(stranger)
        stranger.mqtt.publish(f"{a_user}/control/in", b'{"command":"takeoff"}', qos=1)
        time.sleep(1.0)
        assert len(a.got) == 1, a.got  # only the ground's command ever reached A
    finally:
        for client in clients:
            client.close()
