"""``dronefleet sim``'s MAVLink server: many simulated Copters in one :class:`SimWorld`, each on
its own UDP port and system id, so a fleet flies over real MAVLink bytes (docs/DESIGN.md §5, §9).

Vehicle ``i`` (0-based) has system id ``first_system_id + i`` and listens on ``base_port + i``.
One task on the sim clock updates every vehicle's mode logic and telemetry each physics step.
"""

from __future__ import annotations

import asyncio
import logging
from pathlib import Path
from typing import Any

from dronefleet.geo.types import LLA
from dronefleet.sim.camera import SimCamera
from dronefleet.sim.gasfield import GasSensor
from dronefleet.sim.homes import homes_around
from dronefleet.sim.mavlink.copter import SimCopter
from dronefleet.sim.mavlink.endpoint import VehicleEndpoint
from dronefleet.sim.mavlink.params import ParamTable
from dronefleet.sim.world import SimWorld
from dronefleet.tasks import cancel_and_wait

log = logging.getLogger(__name__)


class MavlinkSimServer:
    """Serves the vehicles of ``world`` over MAVLink/UDP."""

    def __init__(
        self,
        world: SimWorld,
        *,
        host: str = "127.0.0.1",
        base_port: int = 14550,
        first_system_id: int = 1,
        pictures_dir: str | Path | None = None,
        signing_key: bytes | None = None,
    ) -> None:
        self.world = world
        self.signing_key = signing_key
        self.host = host
        self.base_port = base_port
        self.first_system_id = first_system_id
        self.pictures_dir = Path(pictures_dir) if pictures_dir is not None else None
        self.endpoints: list[VehicleEndpoint] = []
        self._task: asyncio.Task[None] | None = None

    def add_vehicle(self, home: LLA, *, port: int | None = None, **params: Any) -> VehicleEndpoint:
        """A new vehicle at ``home`` on the next port and system id; ``params`` go to
        :class:`~dronefleet.sim.vehicle.SimVehicle` (e.g. ``initial_charge_pct``)."""
        index = len(self.endpoints)
        system_id = self.first_system_id + index
        vehicle_id = f"SIM_{system_id}"
        vehicle = self.world.add_vehicle(vehicle_id, home, **params)
        camera = SimCamera(vehicle, self.pictures_dir)
        copter = SimCopter(vehicle, camera=camera, params=ParamTable())
        endpoint = VehicleEndpoint(
            copter,
            system_id,
            self.host,
            self.base_port + index if port is None else port,
            gas_sensor=GasSensor(vehicle, self.world.gas_field),
            signing_key=self.signing_key,
        )
        self.endpoints.append(endpoint)
        return endpoint

    async def start(self) -> MavlinkSimServer:
        for endpoint in self.endpoints:
            await endpoint.start()
        await self.world.start()
        self._task = asyncio.create_task(self._run(), name="mavlink-sim")
        return self

    async def stop(self) -> None:
        task, self._task = self._task, None
        await cancel_and_wait(task)
        for endpoint in self.endpoints:
            endpoint.close()
        await self.world.stop()

    async def __aenter__(self) -> MavlinkSimServer:
        return await self.start()

    async def __aexit__(self, *exc: object) -> None:
        await self.stop()

    async def _run(self) -> None:
        clock, step = self.world.clock, self.world.step_s
        while True:
            for endpoint in self.endpoints:
                try:
                    endpoint.update()
                except Exception:
                    log.exception("vehicle %d: update failed", endpoint.system_id)
            await clock.sleep(step)


def fleet_server(
    count: int,
    *,
    home: LLA,
    spacing_m: float = 15.0,
    speedup: float = 1.0,
    host: str = "127.0.0.1",
    base_port: int = 14550,
    battery_pct: float = 100.0,
    plumes: list[tuple[float, float, float, float]] | None = None,
    pictures_dir: str | Path | None = None,
    first_system_id: int = 1,
    signing_key: bytes | None = None,
) -> MavlinkSimServer:
    """A world of ``count`` vehicles around ``home``, ready to :meth:`~MavlinkSimServer.start`."""
    from dronefleet.sim.gasfield import GasField, Plume

    field = GasField(
        [Plume(LLA(lat, lon), peak_ppm=peak, radius_m=r) for lat, lon, peak, r in plumes or []]
    )
    world = SimWorld(speedup=speedup, gas_field=field)
    server = MavlinkSimServer(
        world,
        host=host,
        base_port=base_port,
        pictures_dir=pictures_dir,
        first_system_id=first_system_id,
        signing_key=signing_key,
    )
    for spot in homes_around(home, count, spacing_m):
        server.add_vehicle(LLA(spot.lat, spot.lon, home.alt_m), initial_charge_pct=battery_pct)
    return server
