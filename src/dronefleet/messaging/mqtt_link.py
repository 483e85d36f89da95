"""One MQTT link to one broker node, made with aiomqtt: the client set up, the CONNACK awaited,
subscriptions made on it.

aiomqtt waits its whole timeout (10 s) for a CONNACK even when the broker has closed the link,
and the connect of a client that gave up on it leaves the socket open: both are made right here.
Its SUBSCRIBE waits for the SUBACK until its timeout even when the link is gone, and treats a
refused filter (SUBACK 0x80) as subscribed: :func:`subscribed` waits while the link holds and
says which filters the broker took.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator, Awaitable, Sequence
from typing import Any, TypeVar

import aiomqtt

T = TypeVar("T")

#: How long a SUBSCRIBE waits for its SUBACK while its link holds. A NATS node that takes a
#: persistent session over restores the session's QoS 1 subscriptions (one JetStream consumer
#: each) before it reads the next packet, each given up after 5 s while its consumer has no
#: leader yet (a node just killed led it). With aiomqtt's 10 s a drone with three such
#: consumers gave up on every link at 10 s: the next node began the restore again, and its save
#: of the session closed the link the first was still restoring for (NATS: "Closing because a
#: remote connection has started with the same client ID"); cut off 26 s on a loaded host.
SUBACK_WAIT_S = 60.0
#: A SUBACK's code for a filter the broker refused (MQTT 3.1.1 §3.9.3).
SUBACK_REFUSED = 0x80


def closed_before_connack_fails(connection: aiomqtt.Client) -> None:
    """Make a link the broker closes before its CONNACK fail the connect at once. aiomqtt
    ignores such a close and waits for the CONNACK until its timeout: a NATS node that cannot
    load a persistent session (the session stream's leader was on a node just killed) gives up
    after 5 s and closes the link, and the client waited 5 s more before trying another node."""
    paho: Any = connection._client
    theirs = paho.on_disconnect

    def on_disconnect(*args: Any) -> None:
        pending: asyncio.Future[Any] = connection._connected
        if not pending.done():
            pending.set_exception(aiomqtt.MqttError("the broker closed the link before CONNACK"))
        paho.on_disconnect = theirs  # once: aiomqtt puts a new future there after a failure
        theirs(*args)

    paho.on_disconnect = on_disconnect


@contextlib.asynccontextmanager
async def linked(
    connection: aiomqtt.Client, connack_s: float | None
) -> AsyncIterator[aiomqtt.Client]:
    """``async with connection``, its CONNACK awaited at most ``connack_s`` (None: aiomqtt's
    own timeout); a connect given up has its socket closed, so no late CONNACK makes a second
    link with the same client id."""
    async with contextlib.AsyncExitStack() as stack:
        try:
            async with asyncio.timeout(connack_s):
                await stack.enter_async_context(connection)
        except TimeoutError:
            with contextlib.suppress(Exception):
                connection._client._sock_close()
            raise aiomqtt.MqttError(f"no CONNACK within {connack_s:g} s") from None
        yield connection


async def while_linked(connection: aiomqtt.Client, operation: Awaitable[T]) -> T:
    """``operation``, ended by an MqttError if ``connection``'s link is lost first."""
    task = asyncio.ensure_future(operation)
    lost: asyncio.Future[None] = connection._disconnected
    try:
        await asyncio.wait((task, lost), return_when=asyncio.FIRST_COMPLETED)
    finally:
        if not task.done():
            task.cancel()
    if task.done() and not task.cancelled():
        return task.result()
    raise aiomqtt.MqttError("the link was lost before the broker answered")


async def subscribed(client: Any, filters: Sequence[tuple[str, int]]) -> list[bool]:
    """SUBSCRIBE ``filters`` (pattern, QoS) in one packet on ``client`` (an aiomqtt client or a
    local bus session, which takes one filter at a time): whether the broker took each."""
    if not isinstance(client, aiomqtt.Client):
        codes: Sequence[Any] = [await client.subscribe(p, qos=q) for p, q in filters]
    else:  # paho takes a list of (filter, QoS) of any length, one filter included
        codes = await while_linked(client, client.subscribe(list(filters), timeout=SUBACK_WAIT_S))
    if len(codes) != len(filters):
        raise aiomqtt.MqttError(f"a SUBACK of {len(codes)} codes for {len(filters)} filters")
    # MQTT 3.1.1 answers a QoS or 0x80 per filter; MQTT 5 a reason code (paho's ReasonCode).
    return [int(getattr(code, "value", code)) < SUBACK_REFUSED for code in codes]
