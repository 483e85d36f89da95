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

The watch keeps one link (a clean session) to each node of a cluster. A link that was up and is
lost starts a failover, which lasts until the cluster is **seen working again**, not for a time
guessed once: every second, each node still linked is sent a QoS 1 message on the watch's own
topic (``ground/probe/...``), which comes back only once the node can store it and deliver it (the
MQTT streams have leaders again). Once every linked node has passed, clients cut off meanwhile
are given :data:`SETTLE_S` for their link (a CONNACK waited for, and a pause: node_turns.py), and
only then is silence counted again. A fixed time was not enough: on a loaded host the cluster
once took more than its 25 s, and a drone on a surviving node was declared lost (the loaded test
of tests/integration/ground/test_mission_on_a_cluster.py, 1 run in 4). It stays the shortest
failover (:data:`FAILOVER_S`), for a node whose host died without closing its sockets, whose
drones find out only through their keep-alive. A cluster not working after
:data:`FAILOVER_MAX_S` is down, not failing over: silence counts again, as on a lost single
broker. On a single broker there is nothing to watch: its loss is the watcher's own link's loss.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import math
import secrets

from dronefleet.clock import monotonic
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.node_turns import CONNACK_MAX_S
from dronefleet.messaging.topics import ground
from dronefleet.messaging.url import BrokerUrl

log = logging.getLogger(__name__)

#: Wall seconds a cluster is taken to be failing over after one of its nodes was lost: the
#: slowest return measured (23 s, above), rounded up. A drone is declared lost only after it
#: and its own 3 heartbeats of silence more; one that died with the node is found that late.
FAILOVER_S = 25.0
#: Longest a failover is waited out: a cluster not working by then is down.
FAILOVER_MAX_S = 120.0
#: Seconds between two probes of the linked nodes while the cluster fails over, and how long a
#: probe's message is given to come back.
PROBE_EVERY_S = 1.0
PROBE_WAIT_S = 2.0
#: After the cluster works again, how long a client cut off meanwhile needs for its link: an
#: attempt made during the failover waits up to its longest CONNACK, then a pause, then one more.
SETTLE_S = CONNACK_MAX_S + 1.0
#: Keep-alive of the watching links (s): a node that dies without closing its sockets (a host
#: lost, not a process killed) is noticed within 1.5 times this.
WATCH_KEEPALIVE_S = 5


class NodeWatch:
    """One idle link per node of ``url``'s cluster (none for a single broker)."""

    def __init__(
        self,
        url: str | BrokerUrl,
        client_id: str,
        *,
        failover_s: float = FAILOVER_S,
        settle_s: float = SETTLE_S,
    ):
        url = BrokerUrl.parse(url) if isinstance(url, str) else url
        self.failover_s = failover_s
        self.settle_s = settle_s
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
        self.working_at = -math.inf  # when every linked node last passed a probe after a loss
        self.nodes_lost = 0
        self._topics = [ground("probe", link.client_id) for link in self.links]
        self._back: dict[str, asyncio.Event] = {}  # a probe's token -> set when it came back
        self._prober: asyncio.Task[None] | None = None

    async def start(self) -> NodeWatch:
        for link, topic in zip(self.links, self._topics, strict=True):
            await link.subscribe(topic, self._came_back, qos=1)
            await link.start(timeout_s=None)  # a node down now is watched from when it comes up
        if self.links:
            self._prober = asyncio.create_task(self._probe_while_failing_over(), name="node-probe")
        return self

    async def stop(self) -> None:
        if self._prober is not None:
            self._prober.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._prober
            self._prober = None
        for link in self.links:
            with contextlib.suppress(Exception):
                await link.stop()

    def failing_over(self, now: float | None = None) -> bool:
        """Whether the cluster is failing over (looked at now): a node's link was lost less than
        :attr:`failover_s` ago, or since then the linked nodes have not all passed a probe, or
        passed less than :attr:`settle_s` ago; never longer than :data:`FAILOVER_MAX_S`."""
        now = monotonic() if now is None else now
        self._look(now)
        since = now - self.lost_at
        if since < self.failover_s:
            return True
        if since >= FAILOVER_MAX_S:
            return False
        return self.working_at < self.lost_at or now - self.working_at < self.settle_s

    def _look(self, now: float) -> None:
        """Note a link that was up and is down now: a node lost."""
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

    async def _probe_while_failing_over(self) -> None:
        while True:
            await asyncio.sleep(PROBE_EVERY_S)
            started = monotonic()
            self._look(started)
            if self.working_at >= self.lost_at or started - self.lost_at >= FAILOVER_MAX_S:
                continue
            linked = [i for i, link in enumerate(self.links) if link.connected]
            passed = await asyncio.gather(*(self._probe(i) for i in linked))
            if linked and all(passed) and self.lost_at < started:
                self.working_at = monotonic()
                log.warning(
                    "broker cluster working again %.1f s after losing a node (%d of %d nodes "
                    "linked); drones' silence counts again in %g s",
                    self.working_at - self.lost_at,
                    len(linked),
                    len(self.links),
                    self.settle_s,
                )

    async def _probe(self, i: int) -> bool:
        """Whether a QoS 1 message sent to node ``i`` came back within :data:`PROBE_WAIT_S`."""
        token = secrets.token_hex(8)
        back = self._back[token] = asyncio.Event()
        try:
            async with asyncio.timeout(PROBE_WAIT_S):
                await self.links[i].publish(self._topics[i], token.encode(), qos=1)
                await back.wait()
            return True
        except TimeoutError:
            return False
        finally:
            del self._back[token]

    async def _came_back(self, _topic: str, payload: bytes) -> None:
        back = self._back.get(payload.decode(errors="replace"))
        if back is not None:
            back.set()
