"""One subscription of a broker client: its bounded, ordered queue and the worker that empties it.

Each subscription has its own queue and worker, so a slow handler never holds up another topic.
A full queue drops its oldest message (a flood must not delay what comes after it); a handler that
raises is logged and the message dropped: a component never dies on input.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field

from dronefleet.messaging.acks import AckTicket
from dronefleet.messaging.log_throttle import LogThrottle
from dronefleet.messaging.memory import release_freed_memory_soon

log = logging.getLogger(__name__)
_throttle = LogThrottle(log)

#: Messages and bytes waiting per subscription; beyond either the oldest are dropped (counted).
QUEUE_LIMIT = 2_000
QUEUE_BYTES = 4 * 1024 * 1024
#: After this many messages, once its queue is empty, a subscription gives freed memory back
#: (messaging/memory.py; at most once per 5 s in a process).
TRIM_AFTER = 200
#: Larger messages are dropped (and counted) before any parsing: a mission of the most steps
#: allowed (messaging/missions.py, 10,000) is about 1.5 MB.
MAX_PAYLOAD_BYTES = 2 * 1024 * 1024

Handler = Callable[[str, bytes], Awaitable[None]]


@dataclass
class Subscription:
    pattern: str
    handler: Handler
    qos: int
    queue: asyncio.Queue[tuple[str, bytes, AckTicket | None]] = field(
        default_factory=lambda: asyncio.Queue(QUEUE_LIMIT)
    )
    worker: asyncio.Task[None] | None = None
    dropped: int = 0  # the oldest messages pushed out of a full queue, and oversized ones
    queued_bytes: int = 0
    since_trim: int = 0  # messages taken since freed memory was last given back
    failed: int = 0  # messages its handler raised on
    #: The filters held at the broker for it, each within ``pattern``, when narrower than the
    #: pattern (BrokerClient.narrow: a ground replica's own drones); None: the pattern itself.
    at_broker: frozenset[str] | None = None


def offer(
    sub: Subscription, topic_name: str, payload: bytes, ticket: AckTicket | None, client_id: str
) -> None:
    """Queue a message for ``sub``: an oversized one is dropped, and a full queue drops its
    oldest messages first (each dropped message's ``ticket`` share is done)."""
    if len(payload) > MAX_PAYLOAD_BYTES:
        if ticket is not None:
            ticket.done()
        sub.dropped += 1
        _throttle.log(logging.WARNING, f"big:{sub.pattern}", "%s: a %d-byte message on %s "
                      "dropped (limit %d)", client_id, len(payload), topic_name,
                      MAX_PAYLOAD_BYTES)  # fmt: skip
        return
    while sub.queue.full() or sub.queued_bytes + len(payload) > QUEUE_BYTES:
        # A flood must not delay what comes after it: the oldest waiting message goes.
        _, old, old_ticket = sub.queue.get_nowait()
        if old_ticket is not None:
            old_ticket.done()
        sub.queued_bytes -= len(old)
        sub.dropped += 1
        what = "%s: queue for %s full; dropped its oldest message"
        _throttle.log(logging.WARNING, f"full:{sub.pattern}", what, client_id,
                      sub.pattern)  # fmt: skip
    sub.queue.put_nowait((topic_name, payload, ticket))
    sub.queued_bytes += len(payload)


async def work(sub: Subscription) -> None:
    """The worker of ``sub``: its handler called on each queued message, in order."""
    while True:
        if sub.since_trim >= TRIM_AFTER and sub.queue.empty():
            release_freed_memory_soon()
            sub.since_trim = 0
        topic_name, payload, ticket = await sub.queue.get()
        sub.since_trim += 1
        sub.queued_bytes -= len(payload)
        try:
            await sub.handler(topic_name, payload)
        except asyncio.CancelledError:
            raise  # not acknowledged: delivered again to the next session
        except Exception:
            sub.failed += 1
            what = "handler for %s failed on a message from %s; dropped"
            _throttle.log(logging.ERROR, f"fail:{sub.pattern}", what, sub.pattern,
                          topic_name, exc=True)  # fmt: skip
        if ticket is not None:
            ticket.done()
