"""Ground replicas share the fleet by drone (issue 27, ``dronefleet ground --partition-fleet``).

Without it, every replica reads the whole fleet's telemetry through its Fleet Inbox, so a
deployment carries, however many hosts, what one replica reads. Partitioned, each drone has one
**owner** among the live replicas (ground/members.py) and only its owner takes its telemetry from
the broker (5 Hz): stores it, compares it for separation, streams it. The other replicas see it in
the owner's picture, its drones' latest telemetry a few times a second
(ground/picture_share.py), which feeds what needs the whole fleet: the live stream of every web
UI, the Mission Planner's positions and paths, the Identifier's positions, the separation
monitor's neighbours. Heartbeats (one every 5 s a drone) are still read whole by every replica:
they make the fleet (``GET /api/v1/drones``, lost or not) and tell each replica which drones
exist. A drone is taken from its first heartbeat on.

The owner is chosen by **rendezvous hashing** (highest random weight): each replica scores each
drone by a hash of the two names, and the highest score owns it. Every replica computes the same
owner from the same members, with no table to keep; when a replica joins or leaves, only the
drones it gains or loses move (about 1/N of the fleet), each to exactly one other. It is a
dozen lines of the standard library (hashlib's BLAKE2): a consistent-hashing package (uhashring)
would add a ring of virtual nodes to tune for no better spread.

While two replicas' views of the members differ (at most a renewal, 0.5 s, after a change), a
drone may be taken by both (stored twice) or, when its owner has died, by none until the others
see it gone (``members.TTL_S``): that telemetry is lost, as QoS 0 telemetry may be. Nothing a
drone sends at QoS 1 comes this way.
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import logging

from dronefleet.errors import InvalidInput
from dronefleet.ground.inbox import FleetInbox
from dronefleet.ground.members import Membership
from dronefleet.ground.state import StateStore
from dronefleet.messaging.status import Heartbeat

log = logging.getLogger(__name__)


class PartitionNotApplicable(InvalidInput):
    """``--partition-fleet`` does not apply (no shared state, or with --share-ingestion)."""


def _score(member: str, drone_id: str) -> bytes:
    return hashlib.blake2b(f"{member}\0{drone_id}".encode(), digest_size=8).digest()


def owner(drone_id: str, members: tuple[str, ...]) -> str:
    """The replica among ``members`` (not empty) that owns ``drone_id``."""
    return max(members, key=lambda member: _score(member, drone_id))


class FleetPartition:
    """``await FleetPartition(state, inbox, member=...).start()``: keeps ``inbox`` taking the
    telemetry of this replica's own drones (:attr:`own`) as drones appear and replicas come and
    go."""

    def __init__(self, state: StateStore, inbox: FleetInbox, *, member: str) -> None:
        if not inbox.partitioned:
            raise ValueError("a partitioned inbox is needed")
        self.inbox = inbox
        self.member = member
        self.membership = Membership(state, name=member, on_change=self._members_changed)
        self.drones: set[str] = set()  # every drone heard (heartbeats)
        self.own: frozenset[str] = frozenset()  # those this replica owns now
        self.moves = 0  # drones gained from others or given up since the start
        self._known: frozenset[str] = frozenset()  # the drones heard at the last look
        self._taken: frozenset[str] | None = None  # what the broker was last told to send
        self._changed = asyncio.Event()
        self._task: asyncio.Task[None] | None = None

    @property
    def members(self) -> tuple[str, ...]:
        return self.membership.members

    async def start(self) -> FleetPartition:
        await self.membership.start()
        self.inbox.heartbeats.direct("fleet partition", self._heard)
        self._task = asyncio.create_task(self._follow(), name="partition:follow")
        return self

    async def stop(self) -> None:
        await self.inbox.heartbeats.detach("fleet partition")
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None
        await self.membership.stop()  # the others take this replica's drones at their next look

    def owns(self, drone_id: str) -> bool:
        return drone_id in self.own

    def _heard(self, hb: Heartbeat) -> None:
        if hb.drone_id not in self.drones:
            self.drones.add(hb.drone_id)
            if owner(hb.drone_id, self.members) == self.member:
                self._changed.set()

    def _members_changed(self, _members: tuple[str, ...]) -> None:
        self._changed.set()

    async def _follow(self) -> None:
        """Take at the broker what this replica owns now, whenever that changes."""
        while True:
            await self._changed.wait()
            self._changed.clear()
            members = self.members
            own = frozenset(d for d in self.drones if owner(d, members) == self.member)
            if own != self.own:
                # Moved: gained from another replica or given up, not newly heard.
                gained, lost = (own - self.own) & self._known, self.own - own
                self.moves += len(gained) + len(lost)
                log.log(logging.INFO if gained or lost else logging.DEBUG,  # not each new drone
                        "this replica owns %d of %d drones (+%d, -%d moved) among %d replicas",
                        len(own), len(self.drones), len(gained), len(lost),
                        len(members))  # fmt: skip
                self.own = own
            self._known = frozenset(self.drones)
            if own == self._taken:
                continue
            try:
                await self.inbox.take_only(set(own))
            except Exception:
                log.exception("taking the telemetry of %d drones failed; trying again", len(own))
                await asyncio.sleep(0.5)
                self._changed.set()
                continue
            self._taken = own
