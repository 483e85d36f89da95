"""A drone id is valid on every supported broker: letters, digits, '_' and '-' only, 1-64
(issue 25 item 4).

A '.' used to be allowed: RabbitMQ's MQTT adapter turns ``QUAD.3/telemetry/out`` into the routing
key ``QUAD.3.telemetry.out`` and back into ``QUAD/3/telemetry/out``, so the ground never heard
that drone, and NATS refuses the client ids made from it. Such an id is now refused at every
entry: the drone's command line, the broker users (``credentials add-drone``, ``bridge-config``)
and the ground, which drops and counts a heartbeat that names one.
"""

from __future__ import annotations

import asyncio
import subprocess

import httpx
import pytest

from dronefleet.errors import InvalidInput
from dronefleet.messaging.broker_users import BrokerRole, BrokerUsers
from dronefleet.messaging.client import BrokerClient
from support.ground_api import local_ground
from support.heartbeats import heartbeat
from support.processes import dronefleet

pytestmark = pytest.mark.integration
REASON = "invalid drone id 'QUAD.3': use 1-64 letters, digits, '_' or '-'"


def said(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line and not line.startswith((" ", "usage:"))]


@pytest.mark.parametrize(
    "args",
    [
        ("drone", "--id", "QUAD.3", "--fc", "sim"),
        ("credentials", "add-drone", "QUAD.3", "--state", "{tmp}/ground.db"),
        ("bridge-config", "--drone-id", "QUAD.3", "--ground", "ground-host:1883"),
    ],
)
def test_an_id_with_a_dot_is_one_line_and_exit_2(args, tmp_path):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in args]
    done = subprocess.run(dronefleet(*argv), capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    (line,) = said(done.stderr)
    assert REASON in line


def test_no_broker_user_is_made_for_an_id_with_a_dot():
    with pytest.raises(InvalidInput, match="letters, digits, '_' or '-'"):
        BrokerUsers().add("QUAD.3", BrokerRole.DRONE)


async def test_a_heartbeat_naming_an_id_with_a_dot_is_dropped_and_counted(
    embedded_broker, tmp_path
):
    ground = local_ground(embedded_broker, tmp_path, "dotted-id-planner")
    async with ground:
        auth = {"Authorization": f"Bearer {ground.operator_token}"}
        async with (
            httpx.AsyncClient(base_url=ground.http_url, headers=auth, timeout=30) as api,
            BrokerClient(embedded_broker, "forger") as forger,
        ):
            await forger.publish("QUAD.3/heartbeats/out", heartbeat("QUAD.3", 1.0), qos=1)
            await forger.publish(
                "QUAD_3/heartbeats/out", heartbeat("QUAD_3", 1.0), qos=1
            )  # the control

            async def seen() -> set[str]:
                return {d["drone_id"] for d in (await api.get("/api/v1/drones")).json()}

            async with asyncio.timeout(20):
                while "QUAD_3" not in await seen():
                    await asyncio.sleep(0.2)
                while (
                    not (await api.get("/api/v1/health"))
                    .json()["dropped_messages"]
                    .get("malformed heartbeat")
                ):
                    await asyncio.sleep(0.2)
            assert "QUAD.3" not in await seen()
            assert (await api.get("/api/v1/drones/QUAD.3")).status_code in (404, 422)
