"""Ground services on a Mosquitto of their own, with fake drones (tests/support/ground_fakes.py)."""

from __future__ import annotations

import httpx
import pytest

from dronefleet.ground.services import GroundServices
from support.brokers import mosquitto
from support.ground_fakes import FakeDrone


@pytest.fixture
def broker(tmp_path):
    """A Mosquitto of the test's own (amqtt's shutdown has been seen to hang in teardown)."""
    with mosquitto(tmp_path) as url:
        yield url


@pytest.fixture
async def ground(broker, tmp_path):
    services = GroundServices(
        broker,
        store_url=f"sqlite:///{tmp_path}/telemetry.db",
        state_path=tmp_path / "ground.db",
        http_port=0,
        command_timeout_s=1.5,
    )
    async with services:
        yield services


@pytest.fixture
async def drone(broker):
    fake = FakeDrone(broker, "QUAD_1", telemetry_hz=20)
    await fake.start()
    yield fake
    await fake.stop()


@pytest.fixture
async def api(ground):
    headers = {"Authorization": f"Bearer {ground.operator_token}"}
    async with httpx.AsyncClient(base_url=ground.http_url, headers=headers, timeout=10) as client:
        yield client
