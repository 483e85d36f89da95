"""A simulated run's broker links survive while its virtual time stands still (the demo on a busy
host, tests/e2e: the ground's six idle subscribers were closed by the broker at once).

On a :class:`~dronefleet.virtual_loop.VirtualTimeLoop` time stands still while a thread works for
the loop (a disk write, a planning job), however long that takes on a busy host. The broker is a
process of its own and keeps wall time: it closes a client silent for 1.5 keepalives. A client
that only listens has nothing to say but its keepalive pings, and those were timed on the
loop's (virtual) clock, so they stopped with it.
"""

from __future__ import annotations

import asyncio
import time

import pytest

from dronefleet import virtual_loop
from dronefleet.messaging.broker_users import BrokerRole, BrokerUsers
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.nats_broker import NatsBroker

pytestmark = pytest.mark.integration

KEEPALIVE_S = 2  # the broker closes a link silent for 3 s


async def _a_listener_through_a_still_spell(still_wall_s: float) -> tuple[int, int, int]:
    broker = NatsBroker(users=BrokerUsers())
    await broker.start()
    try:
        url = broker.url_for("ground", BrokerRole.GROUND)
        got: asyncio.Queue[bytes] = asyncio.Queue()
        listener = BrokerClient(url, "listener", keepalive_s=KEEPALIVE_S)
        talker = BrokerClient(url, "talker", keepalive_s=KEEPALIVE_S)

        async def heard(_topic: str, payload: bytes) -> None:
            got.put_nowait(payload)

        await listener.subscribe("ground/still/+", heard)
        async with listener, talker:
            await talker.publish("ground/still/a", b"before")
            assert await asyncio.wait_for(got.get(), 10) == b"before"
            loop = asyncio.get_running_loop()
            t0 = loop.time()
            # A thread's job the loop waits for: virtual time stands still all along.
            await virtual_loop.held(asyncio.to_thread(time.sleep, still_wall_s))
            still_virtual_s = loop.time() - t0
            await asyncio.sleep(0.5)  # a link the broker closed is seen closed by now
            await talker.publish("ground/still/a", b"after")
            assert await asyncio.wait_for(got.get(), 10) == b"after"
            assert still_virtual_s < 0.2, still_virtual_s  # the spell really was still
            return listener.connections, talker.connections, int(still_virtual_s)
    finally:
        await broker.stop()


#: Finite only: with a separate process as the broker, an unpaced loop (``--speedup max``) is not
#: a supported run (virtual_loop.py: the broker's answers come "late" in virtual time).
@pytest.mark.parametrize("speedup", [1.0, 5.0])
def test_a_listening_link_is_kept_while_virtual_time_stands_still(speedup):
    listener, talker, _ = virtual_loop.run(
        _a_listener_through_a_still_spell(3 * KEEPALIVE_S), speedup=speedup
    )
    assert (listener, talker) == (1, 1), "a link was closed by the broker and made again"
