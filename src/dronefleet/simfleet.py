"""Simulated drones: the whole drone software on simulated vehicles, many per process.

One :class:`~dronefleet.sim.world.SimWorld` (one clock, one physics step) carries every vehicle;
each drone gets its own :class:`DroneApp` with its own broker connections, exactly as a real drone
would. Used by ``dronefleet drone --fc sim``, the demo, the experiments and the tests.
"""

from __future__ import annotations

import asyncio
from collections.abc import Sequence
from typing import Any

from dronefleet.drone.app import DroneApp
from dronefleet.drone.config import DroneConfig
from dronefleet.geo.types import LLA
from dronefleet.messaging.url import BrokerUrl
from dronefleet.sim.camera import SimCamera
from dronefleet.sim.flight_controller import SimFlightController
from dronefleet.sim.gasfield import GasField, GasSensor, Plume
from dronefleet.sim.world import SimWorld


class SimFleet:
    """A simulated world and the drones flying in it."""

    def __init__(
        self,
        *,
        speedup: float = 1.0,
        plumes: list[tuple[float, float, float, float]] | None = None,
        step_s: float = 0.05,
    ) -> None:
        self.gas_field = GasField(
            plumes=[
                Plume(LLA(lat, lon), peak_ppm=peak, radius_m=r)
                for lat, lon, peak, r in plumes or []
            ]
        )
        self.world = SimWorld(speedup=speedup, step_s=step_s, gas_field=self.gas_field)
        self.apps: dict[str, DroneApp] = {}

    @property
    def clock(self):
        return self.world.clock

    async def start(self) -> SimFleet:
        await self.world.start()
        return self

    async def stop(self) -> None:
        # Stop every drone at once, each given a bounded time: a broker that is gone or swamped
        # must not keep the process from ending.
        tasks = [asyncio.ensure_future(app.stop()) for app in self.apps.values()]
        if tasks:
            _, pending = await asyncio.wait(tasks, timeout=10.0)
            for task in pending:
                task.cancel()
        self.apps.clear()
        await self.world.stop()

    async def __aenter__(self) -> SimFleet:
        return await self.start()

    async def __aexit__(self, *exc: object) -> None:
        await self.stop()

    async def add_drone(
        self,
        config: DroneConfig,
        broker: str | BrokerUrl,
        *,
        home: LLA,
        battery_pct: float = 100.0,
        start: bool = True,
        **vehicle_params: Any,
    ) -> DroneApp:
        """Put a vehicle at ``home`` and start the drone software on it."""
        vehicle = self.world.add_vehicle(
            config.drone_id, home, initial_charge_pct=battery_pct, **vehicle_params
        )
        fc = SimFlightController(vehicle, self.world.clock)
        sensors = {"CO2": GasSensor(vehicle, self.gas_field)}
        pictures = config.log_dir / "pictures" if config.log_dir is not None else None
        camera = SimCamera(vehicle, pictures)
        return await self.launch(config, fc, broker, sensors=sensors, camera=camera, start=start)

    async def add_drones(
        self,
        drones: Sequence[tuple[DroneConfig, str | BrokerUrl, LLA]],
        *,
        at_once: int = 50,
        **vehicle_params: Any,
    ) -> list[DroneApp]:
        """:meth:`add_drone` for each ``(config, broker, home)``, up to ``at_once`` starting at a
        time: a drone's start is a few broker round trips (connect, its subscriptions), which a
        broker in another process answers in milliseconds each, so a fleet of hundreds started
        one by one took minutes. The vehicles and apps are made in the order given."""
        apps = [
            await self.add_drone(config, broker, home=home, start=False, **vehicle_params)
            for config, broker, home in drones
        ]
        gate = asyncio.Semaphore(max(1, at_once))

        async def start(app: DroneApp) -> None:
            async with gate:
                await app.start()

        await asyncio.gather(*(start(app) for app in apps))
        return apps

    async def launch(
        self,
        config: DroneConfig,
        fc: Any,
        broker: str | BrokerUrl,
        *,
        sensors: dict[str, Any],
        camera: Any,
        start: bool = True,
    ) -> DroneApp:
        """The drone software on ``fc``, kept with the fleet (stopped with it), started if asked."""
        app = DroneApp(config, fc, broker, sensors=sensors, camera=camera)
        self.apps[config.drone_id] = app
        if start:
            await app.start()
        return app
