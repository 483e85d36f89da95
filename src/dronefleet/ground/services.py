"""All ground services in one process (seed Fig. 3.7 minus the Mission Planner).

:class:`GroundServices` starts the state store, the Drone Identifier, the Telemetry Analyzer's
connector and store, the Drone Manager (gateway, live stream hub, HTTP server), the Mission
Planner and the separation monitor (ground/separation_monitor.py). The fleet's stream
(telemetry and heartbeats, nearly every message a ground receives) comes once, through the Fleet
Inbox (ground/inbox.py), which reads each message once and hands the model to every service in
process; each component keeps its own broker connection for the rest and talks to the others
through the ground broker. ``dronefleet ground`` and ``dronefleet demo`` both use it.

With the state in SQLite (the default) the ground is alone on its broker (ground/presence.py)
and runs the Mission Planner from the start. With the state in PostgreSQL it is one of any number
of replicas: each serves REST and the web apps, and the one holding the lease
(ground/lease.py) runs the Mission Planner and its picture collector; a standby starts them when
it takes the lease over, and a leader that loses it (or the database) stops them.
"""

from __future__ import annotations

import asyncio
import logging
import secrets
import socket
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from dronefleet.ground.alarm_log import AlarmLog
from dronefleet.ground.fleet import MIN_LOST_AFTER_S
from dronefleet.ground.identifier import DroneIdentifier
from dronefleet.ground.inbox import OVER_NATS, FleetInbox
from dronefleet.ground.lease import Lease
from dronefleet.ground.manager.app import create_app
from dronefleet.ground.manager.auth import Role, TokenBook
from dronefleet.ground.manager.context import ManagerContext
from dronefleet.ground.manager.gateway import DroneGateway
from dronefleet.ground.manager.geocoder import Geocoder
from dronefleet.ground.manager.health import GroundHealth
from dronefleet.ground.manager.http_server import HttpServer
from dronefleet.ground.manager.mbtiles import MBTiles, is_tile_url
from dronefleet.ground.manager.stream import StreamHub
from dronefleet.ground.partition import FleetPartition, PartitionNotApplicable
from dronefleet.ground.photos.collector import PhotoCollector
from dronefleet.ground.photos.store import PhotoStore
from dronefleet.ground.picture_share import PictureShare
from dronefleet.ground.planner.service import MissionPlanner
from dronefleet.ground.planner.worker import DEFAULT_BUDGET_S, PlanningWorker
from dronefleet.ground.presence import GroundPresence
from dronefleet.ground.separation_monitor import SeparationMonitor
from dronefleet.ground.state import StateStore
from dronefleet.ground.state_pg import is_postgres_url, state_store
from dronefleet.ground.telemetry.connector import TelemetryConnector
from dronefleet.ground.telemetry.shared_ingest import OPTION as SHARE_INGESTION
from dronefleet.ground.telemetry.shared_ingest import SharedIngest
from dronefleet.ground.telemetry.store import TelemetryStore, open_store
from dronefleet.messaging.nats_link import check_usable
from dronefleet.messaging.url import BrokerUrl

log = logging.getLogger(__name__)

STOP_TIMEOUT_S = 3.0


class GroundServices:
    """``await GroundServices(...).start()``; then ``http_url`` and ``operator_token``."""

    def __init__(
        self,
        broker_url: str | BrokerUrl,
        *,
        store_url: str = "sqlite:///dronefleet-telemetry.db",
        state_path: str | Path = "dronefleet-ground.db",
        http_host: str = "127.0.0.1",
        http_port: int = 8080,
        token: str | None = None,
        admin_token: str | None = None,
        command_timeout_s: float = 30.0,
        serve_http: bool = True,
        planner_client_id: str = "ground-planner",
        planning_processes: int = 1,
        planning_budget_s: float = DEFAULT_BUDGET_S,
        lost_after_s: float = MIN_LOST_AFTER_S,
        tiles: str | Path | None = None,
        geocoder: str | None = None,
        photo_dir: str | Path | None = None,
        trusted_proxies: Sequence[str] = (),
        share_ingestion: str | None = None,
        partition_fleet: bool = False,
        fleet_over_nats: str | None = None,
    ) -> None:
        #: NATS's client address: the Fleet Inbox reads the stream there, not over MQTT
        #: (messaging/nats_link.py); None: over the broker's MQTT.
        self.fleet_over_nats = fleet_over_nats
        #: Share the fleet by drone among the replicas (ground/partition.py): each takes only
        #: its own drones' telemetry from the broker, the others' from their pictures.
        self.partition_fleet = partition_fleet
        self.partition: FleetPartition | None = None
        self.pictures: PictureShare | None = None
        #: NATS's client address: store only this replica's share of the telemetry, taken in a
        #: queue group (ground/telemetry/shared_ingest.py); None: store all the inbox reads.
        self.share_ingestion = share_ingestion
        self.shared_ingest: SharedIngest | None = None
        #: Reverse proxies whose ``X-Forwarded-For`` names the client (addresses or networks);
        #: none by default, so the header is ignored and the peer is the client (issue 25).
        self.trusted_proxies = list(trusted_proxies)
        self.geocoder_url = geocoder  # a Nominatim-compatible geocoder for the maps' search
        # The drones' pictures, per mission (ground/photos): beside the state DB by default
        # (in the current folder when the state is a database server's).
        beside = Path(".") if is_postgres_url(state_path) else Path(state_path).parent
        self.photo_dir = Path(photo_dir) if photo_dir else beside / "photos"
        #: Map imagery for the web maps: a tile server's URL template or an MBTiles file.
        self.tiles = tiles
        self.lost_after_s = lost_after_s  # a drone unheard this long (at least) is lost
        self.broker_url = (
            broker_url if isinstance(broker_url, BrokerUrl) else BrokerUrl.parse(broker_url)
        )
        self.store_url = store_url
        self.state_path = str(state_path)
        self.http_host = http_host
        # 0: a free port, chosen by the system when the socket is bound (never found free first
        # and bound later, which another process could take in between); kept for restarts.
        self.http_port = http_port
        self.command_timeout_s = command_timeout_s
        self.serve_http = serve_http
        self.planner_client_id = planner_client_id
        # Planning runs in worker processes with a budget (0: inline, for virtual time); the
        # processes are started again when a stopped planner is started again.
        self.planning = PlanningWorker(processes=planning_processes, budget_s=planning_budget_s)
        self._given_token = token
        self._given_admin_token = admin_token
        self.operator_token: str | None = None
        self.admin_token: str | None = None
        self.state: StateStore | None = None
        self.inbox: FleetInbox | None = None
        self.alarms: AlarmLog | None = None
        self.telemetry: TelemetryStore | None = None
        self.identifier: DroneIdentifier | None = None
        self.connector: TelemetryConnector | None = None
        self.gateway: DroneGateway | None = None
        self.hub: StreamHub | None = None
        self.planner: MissionPlanner | None = None
        self.separation: SeparationMonitor | None = None
        self.photos: PhotoStore | None = None
        self.photo_collector: PhotoCollector | None = None
        #: Among replicas sharing a PostgreSQL state: the lease on the Mission Planner.
        self.lease: Lease | None = None
        self.replica_id = f"ground-{socket.gethostname()}-{secrets.token_hex(4)}"
        self.app: Any = None
        self._http: HttpServer | None = None
        self._started: list[Any] = []

    @property
    def http_url(self) -> str:
        return f"http://{self.http_host}:{self.http_port}"

    async def start(self) -> GroundServices:
        try:
            await self._start()
        except BaseException:
            await self.stop()
            raise
        return self

    async def _start(self) -> None:
        if self.share_ingestion is not None:
            check_usable(self.broker_url, SHARE_INGESTION)  # refused before anything starts
        if self.fleet_over_nats is not None:
            check_usable(self.broker_url, OVER_NATS)
        if self.partition_fleet and self.share_ingestion is not None:
            raise PartitionNotApplicable(
                "--share-ingestion does not apply with --partition-fleet: each replica already "
                "stores only its own drones' telemetry; leave one out"
            )
        if self.partition_fleet and not is_postgres_url(self.state_path):
            raise PartitionNotApplicable(  # before the state is opened (an SQLite file made)
                "--partition-fleet shares the fleet among replicas on a shared state: give "
                "--state postgresql://...; with an SQLite state there is one ground per broker"
            )
        suffix = secrets.token_hex(3)
        self.state = await state_store(self.state_path).open()
        self._started.append(self.state)
        tokens = TokenBook(self.state)
        await self._tokens(tokens)
        # The alarm log (the web's alarm centre): fed by the planner and the separation monitor,
        # stopped after them (the services stop in reverse order), so the last alarms are kept.
        self.alarms = await AlarmLog(self.state).start()
        self._started.append(self.alarms)

        self.telemetry = open_store(self.store_url)
        await self.telemetry.open()
        self._started.append(self.telemetry)

        url = self.broker_url
        if not self.state.shared:
            # One ground per broker unless the state is shared: the planner's persistent session
            # must not be taken over. Replicas sharing PostgreSQL hold a lease instead.
            presence = GroundPresence(url, planner_id=self.planner_client_id)
            await presence.start()
            self._started.append(presence)
        # The fleet's stream, read once for every service (issue 27); subscribed before any
        # service starts, so the Identifier counts silence from a subscription in place.
        inbox = self.inbox = FleetInbox(
            url,
            client_id=f"ground-inbox-{suffix}",
            partitioned=self.partition_fleet,
            over_nats=self.fleet_over_nats,
        )
        await inbox.start()
        self._started.append(inbox)
        self.identifier = DroneIdentifier(
            url,
            self.state,
            client_id=f"ground-identifier-{suffix}",
            lost_after_s=self.lost_after_s,
            inbox=inbox,
        )
        self.connector = TelemetryConnector(
            url,
            self.telemetry,
            client_id=f"ground-telemetry-{suffix}",
            inbox=inbox,
            from_inbox=self.share_ingestion is None,
        )
        self.gateway = DroneGateway(
            url,
            self.state,
            client_id=f"ground-manager-{suffix}",
            timeout_s=self.command_timeout_s,
            identifier=self.identifier,
        )
        self.hub = StreamHub(url, client_id=f"ground-stream-{suffix}", inbox=inbox)
        self.separation = SeparationMonitor(
            url, client_id=f"ground-separation-{suffix}", inbox=inbox
        )
        self.separation.alarm_listeners.append(self.alarms.on_separation_alarm)
        services = (self.identifier, self.connector, self.gateway, self.hub, self.separation)
        for service in services:
            await service.start()
            self._started.append(service)
        if self.share_ingestion is not None:
            self.shared_ingest = SharedIngest(
                self.share_ingestion, url, take=self.connector.take, name=self.replica_id
            )
            await self.shared_ingest.start()
            self._started.append(self.shared_ingest)
        if self.partition_fleet:
            self.pictures = PictureShare(
                url, inbox, replica=self.replica_id, client_id=f"ground-pictures-{suffix}"
            )
            self.partition = FleetPartition(self.state, inbox, member=self.replica_id)
            self.identifier.persists = self.partition.owns  # each record saved by one replica
            for part in (self.pictures, self.partition):
                await part.start()
                self._started.append(part)
        self.photos = PhotoStore(self.photo_dir)

        ctx = ManagerContext(self.state, tokens, self.gateway, self.telemetry, self.hub)
        self.app = create_app(ctx)
        self.app.state.planner = None
        self.app.state.dropped = self.dropped_messages
        self.app.state.separation = self.separation
        self.app.state.alarms = self.alarms
        self.app.state.photos = self.photos
        self.app.state.health = GroundHealth.of(self)  # GET /api/v1/health's probes
        self.app.state.replica = self._role if self.state.shared else None
        self.app.state.partition = self._partition if self.partition is not None else None
        if self.state.shared:
            self.lease = Lease(
                self.state, holder=self.replica_id, on_lead=self._lead, on_follow=self._follow
            )
            await self.lease.start()
            self._started.append(self.lease)
        else:
            await self._lead()
            self._started.append(_Seat(self))
        await self._map_sources()
        if self.serve_http:
            self._http = HttpServer(self.app, self.http_host, self.http_port, self.trusted_proxies)
            self.http_port = await self._http.start()

    async def _lead(self) -> None:
        """Start the Mission Planner and its picture collector (this ground leads)."""
        assert self.state is not None and self.inbox is not None and self.photos is not None
        # The planning worker's process started and its imports done before the first request.
        self.planning.warm("dronefleet.ground.planner.launch", "dronefleet.ground.planner.eta")
        # The planner's broker session is persistent (QoS 1 progress queued while it is down),
        # so its client id is the same across restarts of the ground and across its replicas:
        # the replica that takes the lease over takes the session over with what it queued.
        planner = MissionPlanner(
            self.broker_url, self.state, client_id=self.planner_client_id, worker=self.planning
        )
        self.planner = planner
        assert self.alarms is not None
        planner.add_listener(self.alarms.on_planner_event)
        try:
            await planner.start()
            self.inbox.telemetry.direct("mission planner", planner.on_telemetry)
            # Heartbeats as read once for the whole ground: on a link of the planner's own, a
            # leader read 2,000 a second again at 10,000 drones, a tenth of its loop.
            self.inbox.heartbeats.queued("mission planner", planner.on_heartbeat)
            # The drones' pictures: fetched as their takepic steps are reported (issue 14).
            self.photo_collector = PhotoCollector(
                self.broker_url,
                planner,
                self.photos,
                client_id=f"ground-photos-{secrets.token_hex(3)}",
            )
            await self.photo_collector.start()
        except BaseException:
            await self._follow()
            raise
        self.app.state.planner = planner
        self._refresh_health()

    async def _follow(self) -> None:
        """Stop the Mission Planner and its collector (this ground no longer leads)."""
        if self.app is not None:
            self.app.state.planner = None
        planner, collector = self.planner, self.photo_collector
        self.planner = self.photo_collector = None
        self._refresh_health()  # their broker links, going down now, are no longer probed
        if self.inbox is not None:
            await self.inbox.telemetry.detach("mission planner")
            await self.inbox.heartbeats.detach("mission planner")
        for part in (collector, planner):
            if part is not None:
                try:
                    async with asyncio.timeout(STOP_TIMEOUT_S):
                        await part.stop()
                except Exception:
                    log.exception("stopping %s failed", type(part).__name__)

    def _refresh_health(self) -> None:
        if self.app is None:
            return
        before = getattr(self.app.state, "health", None)
        health = GroundHealth.of(self)
        if before is not None:
            health.started = before.started
        self.app.state.health = health

    def _partition(self) -> dict[str, int]:
        part = self.partition
        assert part is not None
        return {
            "replicas": len(part.members),
            "drones": len(part.drones),
            "own": len(part.own),
            "moved": part.moves,
        }

    def _role(self) -> str:
        return "leader" if self.leading else "standby"

    @property
    def leading(self) -> bool:
        """Whether this ground runs the Mission Planner now (started, and serving REST)."""
        return self.app is not None and self.app.state.planner is not None

    def dropped_messages(self) -> dict[str, int]:
        """Every broker message the ground services refused, by kind (issue 12)."""
        counts: dict[str, int] = self.inbox.dropped_counts() if self.inbox is not None else {}
        counts.update(self.planner.dropped if self.planner is not None else {})
        shared = self.shared_ingest.dropped if self.shared_ingest is not None else {}
        counts.update(self.pictures.dropped if self.pictures is not None else {})
        counts.update({f"shared ingestion: {why}": n for why, n in shared.items()})
        counted_by = (
            ("telemetry", self.connector),
            ("stream", self.hub),
            ("alarm_log", self.alarms),
        )
        for kind, counted in counted_by:
            counts[kind] = counted.dropped if counted is not None else 0
        return {kind: n for kind, n in counts.items() if n}

    async def _map_sources(self) -> None:
        """The web maps' imagery: a URL template is handed to the pages (and allowed by the
        CSP); an MBTiles file is opened read-only and served by the ground itself."""
        self.app.state.web_tiles = None
        self.app.state.mbtiles = None
        self.app.state.geocoder = None
        if self.geocoder_url:
            self.app.state.geocoder = Geocoder(self.geocoder_url)
            self._started.append(self.app.state.geocoder)
        if self.tiles is None:
            return
        if is_tile_url(str(self.tiles)):
            self.app.state.web_tiles = str(self.tiles)
            return
        mbtiles = await MBTiles.open(self.tiles)
        self._started.append(mbtiles)
        self.app.state.mbtiles = mbtiles

    async def _tokens(self, tokens: TokenBook) -> None:
        first_start = not await tokens.has_any()
        if self._given_token:
            self.operator_token = await tokens.issue("operator", Role.OPERATOR, self._given_token)
        elif first_start:  # unless another ground on this state issued it meanwhile
            self.operator_token = await tokens.issue_if_none("operator", Role.OPERATOR)
        if self._given_admin_token:
            self.admin_token = await tokens.issue("admin", Role.ADMIN, self._given_admin_token)
        elif first_start:
            self.admin_token = await tokens.issue_if_none("admin", Role.ADMIN)

    async def stop(self) -> None:
        if self._http is not None:
            await self._http.stop()
            self._http = None
        while self._started:
            service = self._started.pop()
            closing = service.close() if hasattr(service, "close") else service.stop()
            # A broker link that will not close must not keep the process from stopping.
            task = asyncio.ensure_future(closing)
            done, _ = await asyncio.wait({task}, timeout=STOP_TIMEOUT_S)
            if not done:
                log.warning("%s did not stop within %g s", type(service).__name__, STOP_TIMEOUT_S)
                task.cancel()
            elif task.exception() is not None:
                log.error("stopping %s failed: %r", type(service).__name__, task.exception())

    async def __aenter__(self) -> GroundServices:
        return await self.start()

    async def __aexit__(self, *exc: object) -> None:
        await self.stop()


class _Seat:
    """The planner of a ground that is alone on its broker, stopped with the other services."""

    def __init__(self, services: GroundServices) -> None:
        self.services = services

    async def stop(self) -> None:
        await self.services._follow()
