"""Which nodes of a broker cluster are up, seen from here, and whether the cluster is failing over.

When a node of a broker cluster dies, the clients on it lose their links, and the cluster needs
time before the others can take them: NATS 2.9 elects new leaders for the MQTT streams the dead
node led (its Raft election timeouts are 4-9 s), and a session asked for before then is held by
the node until its JetStream request times out (5 s). Meanwhile clients on surviving nodes can
be cut too, when a request of theirs (a QoS 1 message to store) meets a stream with no leader.
Measured on this project's 3-node cluster on a loaded 2-core host (tests/integration/ground/
test_mission_on_a_cluster.py): drones were unheard until 9-23 s after a node's kill, on every
node.
That silence is the broker's, not the drones': the Drone Identifier (ground/identifier.py) does
not count it, as it does not count the ground's own stalls and reconnects.

The watch keeps one idle link (a clean session, no subscription) to each node of a cluster; a
link that was up and is lost marks :data:`FAILOVER_S` of failing over. On a single broker there
is nothing to watch: its loss is the watcher's own link's loss.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math

from dronefleet.clock import monotonic
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.url import BrokerUrl

log = logging.getLogger(__name__)

#: Wall seconds a cluster is taken to be failing over after one of its nodes was lost: the
#: slowest return measured (23 s, above), rounded up. A drone is declared lost only after it
#: and its own 3 heartbeats of silence more; one that died with the node is found that late.
FAILOVER_S = 25.0
#: Keep-alive of the watching links (s): a node that dies without closing its sockets (a host
#: lost, not a process killed) is noticed within 1.5 times this.
WATCH_KEEPALIVE_S = 5


class NodeWatch:
    """One idle link per node of ``url``'s cluster (none for a single broker)."""

    def __init__(self, url: str | BrokerUrl, client_id: str, *, failover_s: float = FAILOVER_S):
        url = BrokerUrl.parse(url) if isinstance(url, str) else url
        self.failover_s = failover_s
        nodes = url.nodes if len(url.nodes) > 1 else ()
        self.links = [
            BrokerClient(
                dataclasses.replace(url, host=node.host, port=node.port, more_nodes=()),
                f"{client_id}-{i}",
                keepalive_s=WATCH_KEEPALIVE_S,
                persistent_session=False,
            )
            for i, node in enumerate(nodes)
        ]
        self._nodes = nodes
        self._up = [False] * len(self.links)
        self.lost_at = -math.inf  # monotonic time a node's link was last lost
        self.nodes_lost = 0

    async def start(self) -> NodeWatch:
        for link in self.links:  # a node down now is watched from when it comes up
            await link.start(timeout_s=None)
        return self

    async def stop(self) -> None:
        for link in self.links:
            with contextlib.suppress(Exception):
                await link.stop()

    def failing_over(self, now: float | None = None) -> bool:
        """Whether a node's link was lost less than :attr:`failover_s` ago (looked at now)."""
        now = monotonic() if now is None else now
        for i, link in enumerate(self.links):
            up = link.connected
            if self._up[i] and not up:
                self.lost_at, self.nodes_lost = now, self.nodes_lost + 1
                log.warning(
                    "broker node %s lost: the cluster fails over; for %g s, drones' silence is "
                    "the broker's, not theirs",
                    self._nodes[i],
                    self.failover_s,
                )
            self._up[i] = up
        return now - self.lost_at < self.failover_s
