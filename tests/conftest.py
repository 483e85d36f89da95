"""Fixtures shared by the whole suite: real brokers."""

from __future__ import annotations

import asyncio

import pytest
from hypothesis import settings

from dronefleet.messaging.embedded import EmbeddedBroker
from dronefleet.virtual_loop import VirtualTimeLoop
from support.brokers import mosquitto

# Wall time on these shared 2-core machines is noisy: no per-example deadlines anywhere.
settings.register_profile("dronefleet", deadline=None)
settings.load_profile("dronefleet")


def pytest_asyncio_loop_factories(config, item):
    """Tests marked ``virtual_time`` run on virtual time at ``--speedup max`` (issue 9): every
    part they start lives in this process, so vehicle seconds cost only the CPU they need.
    Tests that talk to other processes (Mosquitto, ``dronefleet drone``, SITL) keep real time."""
    if item.get_closest_marker("virtual_time"):
        return {"virtual": VirtualTimeLoop}
    return {"wall": asyncio.new_event_loop}


@pytest.fixture
async def embedded_broker():
    async with EmbeddedBroker(anonymous=True) as broker:
        yield broker.url


@pytest.fixture
def mosquitto_broker(tmp_path):
    with mosquitto(tmp_path) as url:
        yield url


@pytest.fixture(params=["embedded", "mosquitto"])
async def broker_url(request, tmp_path):
    """Each test using this runs once on the embedded broker and once on a real Mosquitto."""
    if request.param == "embedded":
        async with EmbeddedBroker(anonymous=True) as broker:
            yield broker.url
    else:
        with mosquitto(tmp_path) as url:
            yield url
