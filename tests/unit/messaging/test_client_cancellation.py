"""A publishing loop stops when cancelled, even if the MQTT library swallows the cancellation."""

from __future__ import annotations

import asyncio

from dronefleet.messaging.client import BrokerClient


class SwallowingLink:
    """Like aiomqtt under Python 3.11's wait_for: a cancel that meets the PUBACK is lost."""

    def __init__(self) -> None:
        self.published = 0
        self.swallow = True

    async def publish(self, *_args, **_kwargs) -> None:
        self.published += 1
        try:
            await asyncio.sleep(0.01)
        except asyncio.CancelledError:
            if not self.swallow:
                raise
            return  # the acknowledgement "arrived": wait_for returns it and drops the cancel


async def test_a_heartbeat_loop_stops_although_the_link_swallows_the_cancel():
    client = BrokerClient("mqtt://127.0.0.1:1", "cancel-test")
    link = SwallowingLink()
    client._client = link  # connected, as far as publish can tell
    client._connected.set()

    async def heartbeats() -> None:
        while True:
            await client.publish("Q/heartbeats/out", b"{}", qos=0, disposable=True)

    task = asyncio.create_task(heartbeats())
    await asyncio.sleep(0.05)
    task.cancel()
    done, _ = await asyncio.wait({task}, timeout=2)
    if not done:  # let the test fail instead of hanging the event loop's teardown
        link.swallow = False
        task.cancel()
    assert done, f"the loop kept publishing after cancel ({link.published} messages)"
    assert task.cancelled()
