"""No one commands a drone without credentials, and a drone speaks only for itself (issue 12).

Against the embedded broker (a NATS server process, messaging/nats_config.py) and a real
Mosquitto started with the password and ACL files `mosquitto_files` writes: the same rules on
both.
"""

from __future__ import annotations

import asyncio
import contextlib
import getpass
import os

import aiomqtt
import pytest

from dronefleet.messaging.broker_acl import mosquitto_files
from dronefleet.messaging.broker_users import BrokerRole, BrokerUsers, check_password
from dronefleet.messaging.embedded import EmbeddedBroker
from dronefleet.messaging.url import BrokerUrl
from support.brokers import MOSQUITTO, mosquitto, wait_port

pytestmark = pytest.mark.integration


@contextlib.asynccontextmanager
async def connect(url: BrokerUrl, **auth):
    async with aiomqtt.Client(url.host, url.port, timeout=5, **auth) as client:
        yield client


async def heard(listener: aiomqtt.Client, seconds: float = 1.0) -> list[tuple[str, bytes]]:
    got = []
    with contextlib.suppress(TimeoutError):
        async with asyncio.timeout(seconds):
            async for message in listener.messages:
                got.append((str(message.topic), bytes(message.payload)))
    return got


async def _rules_hold(url: BrokerUrl, creds: dict[str, str]) -> None:
    def who(name: str) -> dict[str, str]:
        return {"username": name, "password": creds[name]}

    with pytest.raises(aiomqtt.MqttError):
        async with connect(url) as anonymous:
            await anonymous.publish("QUAD_2/control/in", b'{"command":"takeoff"}')
    with pytest.raises(aiomqtt.MqttError):
        async with connect(url, username="QUAD_1", password="wrong"):
            pass
    async with (
        connect(url, **who("ground")) as ground,
        connect(url, **who("QUAD_2")) as quad2,
        connect(url, **who("QUAD_1")) as quad1,
    ):
        await quad2.subscribe("QUAD_2/control/in", qos=1)
        await ground.subscribe("+/alarms/out", qos=1)
        # A drone cannot command another, nor speak on its topics; the ground can command.
        await quad1.publish("QUAD_2/control/in", b"forged", qos=1)
        await quad1.publish("QUAD_2/alarms/out", b"forged alarm", qos=1)
        await ground.publish("QUAD_2/control/in", b"real", qos=1)
        await quad2.publish("QUAD_2/alarms/out", b"real alarm", qos=1)
        assert await heard(quad2) == [("QUAD_2/control/in", b"real")]
        assert await heard(ground) == [("QUAD_2/alarms/out", b"real alarm")]
        # A drone cannot listen to another's commands; the ground cannot forge a drone's answer.
        with contextlib.suppress(aiomqtt.MqttError):
            await quad1.subscribe("QUAD_2/control/in", qos=1)
        await ground.subscribe("+/control/out", qos=1)
        await ground.publish("QUAD_2/control/out", b"forged answer", qos=1)
        await ground.publish("QUAD_2/control/in", b"again", qos=1)
        assert await heard(quad1) == []
        assert await heard(ground, 0.5) == []


async def test_the_embedded_broker_refuses_strangers_and_keeps_drones_to_themselves():
    broker = EmbeddedBroker()
    creds = {
        "ground": broker.users.add("ground", BrokerRole.GROUND),
        "QUAD_1": broker.users.add("QUAD_1", BrokerRole.DRONE),
        "QUAD_2": broker.users.add("QUAD_2", BrokerRole.DRONE),
    }
    async with broker:
        await _rules_hold(broker.url, creds)


async def test_mosquitto_with_the_generated_files_holds_the_same_rules(tmp_path):
    users = BrokerUsers()
    creds = {name: users.add(name, role) for name, role in [
        ("ground", BrokerRole.GROUND), ("QUAD_1", BrokerRole.DRONE), ("QUAD_2", BrokerRole.DRONE),
    ]}  # fmt: skip
    passwords, acl = mosquitto_files(users)
    (tmp_path / "passwd").write_text(passwords)
    (tmp_path / "acl").write_text(acl)
    (tmp_path / "passwd").chmod(0o600)
    (tmp_path / "acl").chmod(0o600)
    for user in users.all():
        assert check_password(creds[user.name], user.password_hash)
    extra = f"password_file {tmp_path / 'passwd'}\nacl_file {tmp_path / 'acl'}\n"
    with mosquitto(tmp_path, extra, anonymous=False) as url:
        await _rules_hold(url, creds)


async def test_the_drones_own_mosquitto_from_bridge_config_refuses_strangers(tmp_path):
    """``bridge-config --listener`` writes the drone's whole Mosquitto: no anonymous client even
    on loopback; the drone's parts log in as the drone and keep to its topics."""
    import subprocess

    from dronefleet.messaging.embedded import free_port
    from support.processes import dronefleet

    secret = tmp_path / "QUAD_1.secret"
    secret.write_text("drone-one-password\n")
    port = free_port()
    args = ("bridge-config", "--drone-id", "QUAD_1", "--ground", f"127.0.0.1:{free_port()}",
            "--username", "QUAD_1", "--password-file", str(secret),
            "--listener", f"127.0.0.1:{port}", "--local-dir", str(tmp_path / "drone"),
            "--owner", getpass.getuser())  # it runs as us (user root below)  # fmt: skip
    done = await asyncio.to_thread(
        subprocess.run, dronefleet(*args), capture_output=True, text=True, check=True
    )
    config = tmp_path / "drone.conf"
    # As root Mosquitto would drop to its own user, which cannot read the 0600 files.
    user = "user root\n" if os.geteuid() == 0 else ""
    config.write_text(done.stdout + f"persistence false\n{user}log_dest file {tmp_path}/m.log\n")
    for name in ("passwords", "acl"):
        assert (tmp_path / "drone" / name).stat().st_mode & 0o777 == 0o600
    assert "drone-one-password" not in (tmp_path / "drone" / "passwords").read_text()
    proc = await asyncio.create_subprocess_exec(MOSQUITTO, "-c", str(config))
    try:
        await asyncio.to_thread(wait_port, "127.0.0.1", port)
        url = BrokerUrl("127.0.0.1", port)
        with pytest.raises(aiomqtt.MqttError):
            async with connect(url) as anonymous:
                await anonymous.publish("QUAD_1/control/in", b'{"command":"takeoff"}')
        me = {"username": "QUAD_1", "password": "drone-one-password"}
        async with connect(url, **me) as worker, connect(url, **me) as controller:
            await controller.subscribe("QUAD_1/control/in", qos=1)
            await worker.subscribe("QUAD_2/#", qos=1)  # refused by the ACL: hears nothing
            await worker.publish("QUAD_2/control/in", b"not mine", qos=1)
            await worker.publish("QUAD_1/control/in", b"mine", qos=1)
            assert await heard(controller) == [("QUAD_1/control/in", b"mine")]
            assert await heard(worker, 0.5) == []
    finally:
        proc.terminate()
        await proc.wait()
