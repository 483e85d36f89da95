"""The drone's outbox (drone/outbox.py): posting never waits; order kept; bounded, drops counted."""

import asyncio

from pydantic import BaseModel

from dronefleet.drone.outbox import Outbox


class Note(BaseModel):
    n: int


class _Broker:
    """Publishes only while ``up`` is set, as a BrokerClient waits out an outage."""

    def __init__(self) -> None:
        self.up = asyncio.Event()
        self.sent: list[int] = []

    async def publish(self, topic_name, message, *, qos=1):
        await self.up.wait()
        self.sent.append(message.n)
        return True


async def test_posting_never_waits_for_the_broker_and_order_is_kept():
    broker = _Broker()
    outbox = Outbox(broker)  # type: ignore[arg-type]
    for n in range(100):
        outbox.post("QUAD_1/mission/out", Note(n=n))  # returns at once, broker down
    await asyncio.sleep(0.01)
    assert broker.sent == [] and outbox.pending == 100
    broker.up.set()
    assert await outbox.drain(timeout_s=5)
    assert broker.sent == list(range(100)) and outbox.sent == 100
    await outbox.close()


async def test_a_full_outbox_drops_the_oldest_and_counts_them():
    broker = _Broker()
    outbox = Outbox(broker, max_pending=10)  # type: ignore[arg-type]
    for n in range(15):
        outbox.post("QUAD_1/mission/out", Note(n=n))
    assert outbox.pending == 10 and outbox.dropped == 5
    broker.up.set()
    assert await outbox.drain(timeout_s=5)
    assert broker.sent[-9:] == list(range(6, 15))  # the newest kept, in order
    await outbox.close()
