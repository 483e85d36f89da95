"""Request/response over MQTT 3.1.1, as the seed does it (Fig. 4.34).

Each request carries a ``request_id`` (16 random bytes, hex); the answer echoes it. A caller that
hears nothing within its timeout gets :class:`RequestTimeout`, never a hang.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

from pydantic import BaseModel

from dronefleet.errors import NoAnswer
from dronefleet.messaging.client import QOS_COMMAND, QOS_STREAM, BrokerClient
from dronefleet.messaging.codec import MessageError, decode_object
from dronefleet.messaging.common import new_request_id

log = logging.getLogger(__name__)


class RequestTimeout(NoAnswer, TimeoutError):
    """No answer arrived in time."""


class Requester:
    """Sends requests and matches the answers by ``request_id``.

    One subscription per reply pattern (e.g. ``+/control/out``) serves every request.
    """

    def __init__(self, client: BrokerClient) -> None:
        self.client = client
        self._pending: dict[str, asyncio.Future[dict[str, Any]]] = {}
        self._from: dict[str, str] = {}  # request id -> the only topic its answer may come on
        self._subscribed: dict[str, asyncio.Future[None]] = {}
        self.foreign = 0  # answers that echoed a pending request id on another topic: ignored

    async def _ensure(self, reply_pattern: str) -> None:
        """Subscribe once per pattern; every request (even one made meanwhile) waits for it."""
        ready = self._subscribed.get(reply_pattern)
        if ready is None:
            # A persistent session acknowledges what it handles only once handled (acks.py):
            # its unacknowledged backlog (progress waiting for the planner's lock) may fill the
            # broker's in-flight window, and an answer at QoS 1 would then wait behind it while
            # the lock's holder waits for that very answer. Answers come at QoS 0 there: an
            # answer is wanted now or never (the request times out).
            qos = QOS_STREAM if self.client.persistent_session else QOS_COMMAND
            ready = asyncio.ensure_future(
                self.client.subscribe(reply_pattern, self._on_reply, qos=qos)
            )
            self._subscribed[reply_pattern] = ready
        await asyncio.shield(ready)

    async def _on_reply(self, topic_name: str, payload: bytes) -> None:
        try:
            data = decode_object(payload)
        except MessageError as exc:
            log.warning("dropping malformed reply on %s: %s", topic_name, exc)
            return
        request_id = str(data.get("request_id"))
        future = self._pending.get(request_id)
        expected = self._from.get(request_id)
        if expected is not None and topic_name != expected:
            # Whoever listens on the request's topic learns its id; only the asked one's own
            # topic is believed (a forged "ok" must not pass for the drone's answer: issue 12).
            self.foreign += 1
            return
        if future is not None and not future.done():
            future.set_result(data)

    async def request(
        self,
        topic_name: str,
        reply_pattern: str,
        message: BaseModel | dict[str, Any],
        *,
        timeout_s: float = 10.0,
        reply_topic: str | None = None,
    ) -> dict[str, Any]:
        """Publish ``message`` with a fresh ``request_id`` and return the matching answer (only
        one that came on ``reply_topic``, when given)."""
        await self._ensure(reply_pattern)
        data = (
            message.model_dump(mode="json", exclude_none=True)
            if isinstance(message, BaseModel)
            else dict(message)
        )
        request_id = data.get("request_id") or new_request_id()
        data["request_id"] = request_id
        future: asyncio.Future[dict[str, Any]] = asyncio.get_running_loop().create_future()
        self._pending[request_id] = future
        if reply_topic is not None:
            self._from[request_id] = reply_topic
        try:
            await self.client.publish(topic_name, data, qos=QOS_COMMAND, timeout_s=timeout_s)
            async with asyncio.timeout(timeout_s):
                return await future
        except TimeoutError as exc:
            raise RequestTimeout(
                f"no answer on {reply_pattern} to request {request_id} within {timeout_s:g} s"
            ) from exc
        finally:
            self._pending.pop(request_id, None)
            self._from.pop(request_id, None)
