"""Fixtures shared by the whole suite: real brokers."""

from __future__ import annotations

import asyncio
import os

import pytest
from hypothesis import settings

from dronefleet.messaging.embedded import EmbeddedBroker
from dronefleet.messaging.local_bus import LocalBus
from dronefleet.virtual_loop import VirtualTimeLoop
from support.brokers import mosquitto

# Wall time on these shared 2-core machines is noisy: no per-example deadlines anywhere.
settings.register_profile("dronefleet", deadline=None)
settings.load_profile("dronefleet")


@pytest.fixture(autouse=True)
def _umask_kept():
    """Each test gets the umask it found back: a ``dronefleet ground``/``drone``/``demo`` run in
    this process makes its files private (``owner_only.private_umask``), and a test that ran
    one left every later test of its worker making 0700 folders (CI: the README's Mosquitto
    could not enter its configuration folder)."""
    umask = os.umask(0o022)
    os.umask(umask)
    yield
    os.umask(umask)


def pytest_asyncio_loop_factories(config, item):
    """Tests marked ``virtual_time`` run on virtual time at ``--speedup max`` (issue 9): every
    part they start lives in this process, so vehicle seconds cost only the CPU they need.
    Tests that talk to other processes (Mosquitto, ``dronefleet drone``, SITL) keep real time."""
    if item.get_closest_marker("virtual_time"):
        return {"virtual": VirtualTimeLoop}
    return {"wall": asyncio.new_event_loop}


def _in_process(request) -> bool:
    """A test on virtual time passes its messages through the in-process bus: a broker process
    would hold messages the virtual clock cannot see (messaging/local_bus.py)."""
    return request.node.get_closest_marker("virtual_time") is not None


@pytest.fixture
async def embedded_broker(request):
    """The embedded default (a broker process), or the in-process bus for a test on virtual
    time; anonymous clients allowed (the security tests use their own users)."""
    kind = LocalBus if _in_process(request) else EmbeddedBroker
    async with kind(anonymous=True) as broker:
        yield broker.url


@pytest.fixture
def mosquitto_broker(tmp_path):
    with mosquitto(tmp_path) as url:
        yield url


@pytest.fixture(params=["embedded", "mosquitto"])
async def broker_url(request, tmp_path):
    """Each test using this runs once on the embedded broker and once on a real Mosquitto."""
    if request.param == "embedded":
        kind = LocalBus if _in_process(request) else EmbeddedBroker
        async with kind(anonymous=True) as broker:
            yield broker.url
    else:
        with mosquitto(tmp_path) as url:
            yield url
