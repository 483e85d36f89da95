"""A drone logs in to RabbitMQ in the fleet's vhost with the URL ``broker-config`` prints, and
takes a picture there (issue 25 item 4).

RabbitMQ's MQTT adapter takes ``VHOST:USER`` as the user name; in a broker URL the ':' is written
``%3A`` (``mqtt://fleet%3AQUAD_1@host:1883``). ``dronefleet credentials`` makes the users,
``dronefleet broker-config --broker rabbitmq --vhost V`` writes the definitions and prints each
user's ``--broker`` URL; a ``dronefleet drone`` process started with the printed one (the host
and port put in) comes up, and the ground's user gets its answer to a ``takepic``: the drone asks
its own camera (``<id>.gear.in``) and hears it (``<id>.gear.out``) under the generated topic
permissions, with its Logger on ``<id>/#``. The vhost and users are removed afterwards.
"""

from __future__ import annotations

import json
import re
import secrets
import subprocess
import time

import paho.mqtt.client as mqtt
import pytest

from support.ground_procs import rabbit_mqtt_or_skip
from support.processes import dronefleet, process

pytestmark = pytest.mark.integration


def _rabbitmqctl(*args: str) -> str:
    done = subprocess.run(["rabbitmqctl", "-q", *args], capture_output=True, text=True, timeout=60)
    return done.stdout


def test_a_drone_logs_in_with_the_printed_vhost_url_and_takes_a_picture(tmp_path) -> None:
    host, port = rabbit_mqtt_or_skip()
    tag = secrets.token_hex(3).upper()
    drone, ground_user, vhost = f"RQV_{tag}", f"rqvground-{tag.lower()}", f"fleet-{tag.lower()}"
    state = tmp_path / "ground.db"
    for action, name in (("add-drone", drone), ("add-ground", ground_user)):
        subprocess.run(
            dronefleet("credentials", action, name, "--state", str(state),
                       "--password-file", str(tmp_path / f"{name}.secret")),
            check=True, capture_output=True,
        )  # fmt: skip
    printed = subprocess.run(
        dronefleet("broker-config", "--broker", "rabbitmq", "--vhost", vhost,
                   "--state", str(state), "--out", str(tmp_path)),
        check=True, capture_output=True, text=True,
    ).stdout  # fmt: skip
    urls = dict(re.findall(r"^  (\S+): --broker (\S+) ", printed, re.MULTILINE))
    assert urls[drone] == f"mqtt://{vhost}%3A{drone}@HOST:1883", printed
    broker = urls[drone].replace("HOST:1883", f"{host}:{port}")
    with open(tmp_path / "rabbitmq-definitions.json", "rb") as given:
        subprocess.run(["rabbitmqctl", "import_definitions"], stdin=given, check=True,
                       capture_output=True, timeout=60)  # fmt: skip
    answers: list[dict] = []
    ground = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"{ground_user}-test")
    try:
        ground.username_pw_set(
            f"{vhost}:{ground_user}", (tmp_path / f"{ground_user}.secret").read_text().strip()
        )
        ground.on_message = lambda _c, _u, m: answers.append(json.loads(m.payload))
        ground.connect(host, port)
        ground.loop_start()
        ground.subscribe(f"{drone}/control/out", qos=1)
        args = dronefleet(
            "drone", "--id", drone, "--broker", broker,
            "--broker-password-file", str(tmp_path / f"{drone}.secret"), "--fc", "sim",
            "--home", "40.63,-8.659,10", "--speedup", "10", "--log-dir", str(tmp_path / "logs"),
        )  # fmt: skip
        with process(args, tmp_path / "drone.log"):
            deadline = time.monotonic() + 30
            while "ready on" not in (tmp_path / "drone.log").read_text():
                assert time.monotonic() < deadline, (tmp_path / "drone.log").read_text()
                time.sleep(0.2)
            ask = {"request_id": "pic-1", "command": "takepic"}
            ground.publish(f"{drone}/control/in", json.dumps(ask), qos=1)
            deadline = time.monotonic() + 20
            while not [a for a in answers if a.get("request_id") == "pic-1"]:
                assert time.monotonic() < deadline, (tmp_path / "drone.log").read_text()
                time.sleep(0.1)
    finally:
        ground.loop_stop()
        ground.disconnect()
        _rabbitmqctl("delete_vhost", vhost)
        for name in (drone, ground_user):
            _rabbitmqctl("delete_user", name)
    (answer,) = [a for a in answers if a.get("request_id") == "pic-1"]
    assert answer["ok"] is True, answer
    assert list((tmp_path / "logs" / "pictures").glob("*.jpg")), "the camera wrote no picture"
