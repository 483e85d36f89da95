"""Which node of a broker cluster a client's link goes to next, and when it pauses first.

The nodes are tried in turn, round-robin (issue 27). A link that held and was lost moves on to
the next node at once: its node is probably gone. A round in which every node has been tried
ends with a pause (the client's ``reconnect_s``), so a cluster that is down, or two clients with
one id taking the session from each other, costs a few attempts a pause, never a busy loop. With
one node this is the old rule: a pause before each new attempt.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

from dronefleet.messaging.url import BrokerNode

#: A link up this long counts as having held: its loss starts a new round of attempts.
STABLE_LINK_S = 2.0
#: How long a node of a cluster is given for its CONNACK in the first round of attempts,
#: doubled after each round without a link, up to aiomqtt's own 10 s. While a NATS cluster
#: elects a new leader for a stream a node was killed with, a request made before the election
#: is never answered (the node gives up after 5 s): asking again soon finds the new leader; a
#: cluster merely slow to answer (a loaded host) is given longer at each round.
CONNACK_FIRST_S = 2.0
CONNACK_MAX_S = 10.0


class NodeTurns:
    def __init__(self, nodes: Sequence[BrokerNode], *, stable_s: float = STABLE_LINK_S) -> None:
        if not nodes:
            raise ValueError("a broker has at least one node")
        self._nodes = tuple(nodes)
        self._stable_s = stable_s
        self._at = 0  # the next node's index
        self._tries = 0  # attempts since the last pause (or since a link that held)
        self._up_since: float | None = None
        self._rounds = 0  # rounds of attempts ended (paused) since the last link

    def next(self) -> BrokerNode:
        """The node to try now."""
        node = self.peek()
        self._at = (self._at + 1) % len(self._nodes)
        self._tries += 1
        return node

    def peek(self) -> BrokerNode:
        """The node :meth:`next` gives."""
        return self._nodes[self._at]

    def connack_s(self) -> float | None:
        """How long the next attempt waits for its CONNACK (None: the client's default, for a
        single node, which has no other to try)."""
        if len(self._nodes) == 1:
            return None
        return min(CONNACK_MAX_S, CONNACK_FIRST_S * 2.0**self._rounds)

    def up(self) -> None:
        """The link to the last node given is made."""
        self._up_since = time.monotonic()
        self._rounds = 0

    def down(self) -> None:
        """The attempt ended (the link lost, or never made)."""
        if self._up_since is not None and time.monotonic() - self._up_since >= self._stable_s:
            self._tries = 1  # a new round, of which the node just lost was the first
        self._up_since = None

    def pause_due(self) -> bool:
        """Whether every node was tried since the last pause: then pause before the next."""
        if self._tries < len(self._nodes):
            return False
        self._tries = 0
        self._rounds += 1
        return True
