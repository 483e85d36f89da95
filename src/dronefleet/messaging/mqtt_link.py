"""One MQTT link to one broker node, made with aiomqtt: the client set up, the CONNACK awaited.

aiomqtt waits its whole timeout (10 s) for a CONNACK even when the broker has closed the link,
and the connect of a client that gave up on it leaves the socket open: both are made right here.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator
from typing import Any

import aiomqtt


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
