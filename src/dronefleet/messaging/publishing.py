"""Publishing over a broker client's link, retried while the broker is away.

Publishing while the broker is away waits for it to come back (QoS 1 messages are never silently
dropped), unless the caller says the message is disposable (heartbeats, telemetry).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from typing import Any

import aiomqtt
from pydantic import BaseModel

from dronefleet.messaging.codec import encode
from dronefleet.messaging.connection import BrokerUnavailable, Connection
from dronefleet.messaging.local_bus import LocalSession, SessionClosed

log = logging.getLogger(__name__)

#: A failed publish waits this long before its next try, doubling up to RETRY_MAX_S.
RETRY_FIRST_S = 0.05
RETRY_MAX_S = 1.0

QOS_COMMAND = 1  # commands, missions, progress, alarms
QOS_STREAM = 0  # heartbeats, telemetry


class Publishing(Connection):
    """A connection that publishes, waiting out broker outages."""

    async def publish(
        self,
        topic_name: str,
        message: BaseModel | dict[str, Any] | bytes,
        *,
        qos: int = QOS_COMMAND,
        retain: bool = False,
        disposable: bool = False,
        timeout_s: float | None = None,
    ) -> bool:
        """Publish; wait out broker outages unless ``disposable``. Returns False if dropped."""
        payload = message if isinstance(message, bytes) else encode(message)
        client = self._client
        if type(client) is LocalSession and self._connected.is_set():
            # The in-process bus, connected: one call (a simulated fleet publishes thousands of
            # messages a second); its suspension point raises a cancellation as it should.
            try:
                await client.publish(topic_name, payload, qos=qos, retain=retain)
                return True
            except SessionClosed as exc:
                log.debug("publish on %s failed (%s); waiting for the bus", topic_name, exc)
                if disposable:
                    return False
        loop = asyncio.get_running_loop()
        deadline = None if timeout_s is None else loop.time() + timeout_s
        backoff_s = RETRY_FIRST_S
        while True:
            client = self._client
            if client is not None and self.connected:
                try:
                    sending = client.publish(topic_name, payload, qos=qos, retain=retain)
                    if qos > 0 and type(client) is aiomqtt.Client:
                        await self._on_link(sending)  # not waiting out a lost link's PUBACK
                    else:
                        await sending
                    _keep_cancellation()
                    return True
                except (aiomqtt.MqttError, SessionClosed) as exc:
                    log.debug("publish on %s failed (%s); waiting for the broker", topic_name, exc)
            if disposable:
                return False
            remaining = None if deadline is None else deadline - loop.time()
            if remaining is not None and remaining <= 0:
                raise BrokerUnavailable(f"broker {self.url} unavailable; {topic_name} not sent")
            # Always a real pause: a link that fails at once while still marked connected
            # made this loop spin without ever yielding, and the whole process hung with it
            # (issue 26: a ground resumed after SIGSTOP answered nothing, 1 GB).
            await asyncio.sleep(min(backoff_s, remaining if remaining is not None else backoff_s))
            backoff_s = min(backoff_s * 2, RETRY_MAX_S)
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(min(remaining or 1.0, 1.0)):
                    await self._connected.wait()
            if self._stopping:
                raise BrokerUnavailable(f"client {self.client_id} stopped; {topic_name} not sent")


def _keep_cancellation() -> None:
    """Raise the cancellation aiomqtt may have lost.

    aiomqtt waits for the broker's acknowledgement with Python 3.11's ``asyncio.wait_for``, which
    returns the result instead of raising when the task is cancelled just as the answer comes.
    The task's cancel request is still counted, so it is honoured here; otherwise a publishing
    loop (heartbeats) would never stop and a process would ignore SIGTERM.
    """
    task = asyncio.current_task()
    if task is not None and task.cancelling():
        raise asyncio.CancelledError
