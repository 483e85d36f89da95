"""A drone connected straight to the ground's Mosquitto has what its parts use, and only under
its own id (issue 25 item 4).

Its Drone Controller asks its own Gear Manager on ``<id>/gear/in`` and hears the answer on
``<id>/gear/out`` (a ``takepic``), its fail-safe follows ``<id>/mission/out`` and its Logger
``<id>/#``. Before, the ACL ``broker-config`` wrote let a drone hear only ``<id>/+/in`` on the
ground's broker, so a drone without a bridge could not take a picture (409). Against a Mosquitto
with the files ``mosquitto_files`` writes: a whole drone (with its Logger) answers a ``takepic``
the ground sends; a drone's client hears its own ``gear/out`` and not another's, and cannot ask
another drone's camera.
"""

from __future__ import annotations

import asyncio
import contextlib
import json

import aiomqtt
import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.geo.types import LLA
from dronefleet.messaging.broker_acl import mosquitto_files
from dronefleet.messaging.broker_users import BrokerRole, BrokerUsers
from dronefleet.messaging.url import BrokerUrl
from dronefleet.simfleet import SimFleet
from support.brokers import mosquitto

pytestmark = pytest.mark.integration
HOME = LLA(40.63, -8.659, 10.0)


@contextlib.contextmanager
def ground_mosquitto(tmp_path):
    """A Mosquitto with the generated password and ACL files; yields (url, passwords)."""
    users = BrokerUsers()
    creds = {name: users.add(name, role) for name, role in [
        ("ground", BrokerRole.GROUND), ("QUAD_1", BrokerRole.DRONE), ("QUAD_2", BrokerRole.DRONE),
    ]}  # fmt: skip
    passwords, acl = mosquitto_files(users)
    for name, text in (("passwd", passwords), ("acl", acl)):
        (tmp_path / name).write_text(text)
        (tmp_path / name).chmod(0o600)
    extra = f"password_file {tmp_path / 'passwd'}\nacl_file {tmp_path / 'acl'}\n"
    with mosquitto(tmp_path, extra, anonymous=False) as url:
        yield url, creds


def connect(url: BrokerUrl, user: str, creds: dict[str, str]) -> aiomqtt.Client:
    return aiomqtt.Client(url.host, url.port, username=user, password=creds[user], timeout=5)


async def heard(client: aiomqtt.Client, seconds: float = 1.0) -> list[tuple[str, bytes]]:
    got = []
    with contextlib.suppress(TimeoutError):
        async with asyncio.timeout(seconds):
            async for message in client.messages:
                got.append((str(message.topic), bytes(message.payload)))
    return got


async def test_a_drone_straight_on_the_ground_broker_takes_a_picture(tmp_path):
    with ground_mosquitto(tmp_path) as (url, creds):
        drone_url = BrokerUrl(url.host, url.port, "QUAD_1", creds["QUAD_1"])
        config = DroneConfig(drone_id="QUAD_1", log_dir=tmp_path / "logs")  # with its Logger
        async with SimFleet(speedup=10) as fleet, connect(url, "ground", creds) as ground:
            await fleet.add_drone(config, drone_url, home=HOME)
            await ground.subscribe("QUAD_1/control/out", qos=1)
            ask = {"request_id": "pic-1", "command": "takepic"}
            await ground.publish("QUAD_1/control/in", json.dumps(ask), qos=1)
            async with asyncio.timeout(20):
                async for message in ground.messages:
                    answer = json.loads(message.payload)
                    if answer.get("request_id") == "pic-1":
                        break
    assert answer.get("ok") is True, answer
    assert "capture" in json.dumps(answer), answer
    assert list((tmp_path / "logs" / "pictures").glob("*.jpg")), "the camera wrote no picture"
    logged = (tmp_path / "logs" / "QUAD_1.jsonl").read_text()
    assert "QUAD_1/gear/out" in logged  # its Logger heard its own topics


async def test_a_drone_hears_its_own_gear_answers_and_never_another_drones(tmp_path):
    with ground_mosquitto(tmp_path) as (url, creds):
        async with (
            connect(url, "QUAD_1", creds) as controller,
            connect(url, "QUAD_1", creds) as gear,
            connect(url, "QUAD_2", creds) as other,
        ):
            await gear.subscribe("QUAD_1/gear/in", qos=1)
            await controller.subscribe("QUAD_1/gear/out", qos=1)
            with contextlib.suppress(aiomqtt.MqttError):  # refused, or hears nothing
                await controller.subscribe("QUAD_2/gear/out", qos=1)
            await controller.publish("QUAD_1/gear/in", b'{"query":"capture"}', qos=1)
            await controller.publish("QUAD_2/gear/in", b'{"query":"capture"}', qos=1)
            assert await heard(gear) == [("QUAD_1/gear/in", b'{"query":"capture"}')]
            await gear.publish("QUAD_1/gear/out", b'{"ok":true}', qos=1)
            await other.publish("QUAD_2/gear/out", b'{"ok":true}', qos=1)
            assert await heard(controller) == [("QUAD_1/gear/out", b'{"ok":true}')]
            # Not even its own commands: only the ground sends those.
            await gear.subscribe("QUAD_1/control/in", qos=1)
            await controller.publish("QUAD_1/control/in", b'{"command":"arm"}', qos=1)
            assert await heard(gear, 0.5) == []
