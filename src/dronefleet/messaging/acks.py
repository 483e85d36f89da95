"""Acknowledging a QoS 1 message only once it has been handled (docs/DESIGN.md §3).

paho acknowledges a message (PUBACK) as soon as it hands it over, so a process killed between
receiving and handling it loses it: the broker counts it delivered. The planner was killed so
right after a drone's CRITICAL alarm reached it, and the replacement never happened (issue 13's
"ground killed right after a replacement alarm", failing under load). With manual acks (paho's
``manual_ack_set``) a client of a persistent session acknowledges each message when every
subscription it matched has handled it (or dropped it); one left unacknowledged when the link or
the process goes is delivered again by the broker, which the handlers take as a duplicate.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

log = logging.getLogger(__name__)


class AckTicket:
    """One received message, acknowledged when its last handler is done with it."""

    __slots__ = ("_acked", "_paho", "mid", "pending", "qos")

    def __init__(
        self, paho: Any, mid: int, qos: int, pending: int, acked: Callable[[], None] | None = None
    ) -> None:
        self._paho = paho  # the connection it came on: after a reconnect it is not acked
        self.mid, self.qos, self.pending = mid, qos, pending
        self._acked = acked  # told once the message is acknowledged (or given up)
        if pending <= 0:
            self._ack()

    def done(self) -> None:
        self.pending -= 1
        if self.pending == 0:
            self._ack()

    @property
    def open(self) -> bool:
        """Not acknowledged yet: some handler still has the message."""
        return self.pending > 0

    def _ack(self) -> None:
        try:
            self._paho.ack(self.mid, self.qos)
        except Exception as exc:  # the link went: the broker will deliver it again
            log.debug("message %d not acknowledged: %s", self.mid, exc)
        if self._acked is not None:
            self._acked()
