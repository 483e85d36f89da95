"""A whole platform for one experiment: broker, ground services, Mission Planner, drones.

Everything runs through the real components — the in-process bus (messaging/local_bus.py: a
broker with the deployment's rules that virtual time can see), the Drone Identifier,
the Mission Planner, each drone's controller and Mission Worker — on simulated vehicles that share
one sim clock, so every duration is in vehicle seconds and comparable with the seed's flights.
"""

from __future__ import annotations

import asyncio
import contextlib
import tempfile
from pathlib import Path
from typing import Any

from dronefleet.drone.config import DroneConfig
from dronefleet.experiments.fleets import FcBackend, ProtocolFleet
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.models import MissionRecord
from dronefleet.ground.planner.service import MissionPlanner
from dronefleet.ground.services import GroundServices
from dronefleet.messaging.broker_users import BrokerRole
from dronefleet.messaging.commands import parse_control
from dronefleet.messaging.local_bus import LocalBus
from dronefleet.sim.clock import SimClock

#: The seed's field: the University of Aveiro campus.
ORIGIN = LLA(40.6300, -8.6590, 10.0)


class Harness:
    def __init__(
        self,
        *,
        speedup: float = 10.0,
        workdir: Path | None = None,
        fc: FcBackend | str = FcBackend.SIM,
    ) -> None:
        self.speedup = speedup
        self._tmp = None if workdir else tempfile.TemporaryDirectory(prefix="dronefleet-exp-")
        self.workdir = workdir if workdir is not None else Path(self._tmp.name)  # type: ignore[union-attr]
        self.broker = LocalBus()
        self.fleet = ProtocolFleet(speedup=speedup, backend=fc)
        self.ground: GroundServices | None = None
        self._planner: MissionPlanner | None = None
        self.events: list[tuple[str, dict[str, Any]]] = []
        self._changed = asyncio.Event()

    @property
    def clock(self) -> SimClock:
        return self.fleet.clock

    @property
    def planner(self) -> MissionPlanner:
        """The running ground's Mission Planner (between :meth:`start_ground` and a stop)."""
        if self._planner is None:
            raise RuntimeError("the ground services are not running (start_ground first)")
        return self._planner

    @property
    def has_planner(self) -> bool:
        return self._planner is not None

    async def __aenter__(self) -> Harness:
        await self.broker.start()
        await self.fleet.start()
        await self.start_ground()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.stop_ground()
        await self.fleet.stop()
        await self.broker.stop()
        if self._tmp is not None:
            with contextlib.suppress(Exception):
                self._tmp.cleanup()

    async def start_ground(self) -> None:
        """(Re)start the ground services and the planner on the same state files."""
        self.ground = GroundServices(
            self.broker.url_for("ground", BrokerRole.GROUND),
            store_url=f"sqlite:///{self.workdir / 'telemetry.db'}",
            state_path=self.workdir / "ground.db",
            serve_http=False,
            planner_client_id="experiment-planner",
            planning_processes=0,  # inline: on virtual time, planning takes no vehicle time
        )
        await self.ground.start()
        planner = self.ground.planner
        assert planner is not None  # GroundServices.start made it
        self._planner = planner
        planner.add_listener(self._on_event)

    async def stop_ground(self) -> None:
        self._planner = None
        if self.ground is not None:
            await self.ground.stop()
            self.ground = None

    def separation(self) -> dict[str, Any]:
        """The separation monitor's counts so far (ground/separation_monitor.py)."""
        if self.ground is None or self.ground.separation is None:
            raise RuntimeError("the ground services are not running (start_ground first)")
        return self.ground.separation.status().model_dump(mode="json", exclude={"active"})

    def _on_event(self, event: str, data: dict[str, Any]) -> None:
        self.events.append((event, data))
        self._changed.set()

    async def add_drone(
        self,
        drone_id: str,
        offset: NED,
        *,
        hovering_m: float | None = None,
        battery_pct: float = 100.0,
        backend: FcBackend | str | None = None,
        **config: Any,
    ) -> LLA:
        """A drone at ``offset`` from the origin: on the ground, or hovering ``hovering_m`` up;
        over ``backend`` (default: the harness's ``fc``)."""
        home = ned_to_lla(NED(offset.n, offset.e, 0.0), ORIGIN)
        app = await self.fleet.add_drone(
            DroneConfig(drone_id=drone_id, heartbeat_interval_s=1.0, **config),
            self.broker.url_for(drone_id, BrokerRole.DRONE),
            home=home,
            battery_pct=battery_pct,
            backend=backend,
        )
        if hovering_m is not None:
            await app.controller.execute(parse_control({"command": "arm"}))
            await app.controller.execute(parse_control({"command": "takeoff", "value": hovering_m}))
            vehicle = self.fleet.vehicle(drone_id)
            while abs(vehicle.relative_alt_m - hovering_m) > 0.2:
                await self.clock.sleep(0.2)
        return home

    async def wait_identified(self, drone_ids: list[str], timeout_s: float = 30.0) -> None:
        """Until the Drone Identifier knows every drone (and its latest state)."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        while True:
            views = {d.drone_id: d for d in await self.planner.fleet.drones()}
            if all(i in views for i in drone_ids):
                return
            if loop.time() > deadline:
                raise TimeoutError(f"drones not identified: {set(drone_ids) - set(views)}")
            await asyncio.sleep(0.2)

    async def settle(self, vehicle_s: float = 2.0) -> None:
        """Let heartbeats carry the drones' latest state to the ground."""
        await self.clock.sleep(vehicle_s)

    async def until_ended(self, mission_id: str, timeout_s: float = 300.0) -> MissionRecord:
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        while True:
            record = self.planner.missions.get(mission_id)
            if record is not None and record.terminal:
                return record
            if loop.time() > deadline:
                state = record.state.value if record else "unknown"
                raise TimeoutError(f"mission {mission_id} still {state} after {timeout_s} s")
            self._changed.clear()
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(0.5):
                    await self._changed.wait()
