"""One drone's software (seed Figure 3.2): Drone Controller with its Mission Worker, Gear Manager,
Fail-safe System and Logger, sharing one connection to the drone's broker (each with its own
subscriptions, queues and workers; the four connections of the seed cost a fleet of 200 in the
demo 800 broker connections, all with the drone's same credentials). The Logger's ``<id>/#``
covers the others' filters: the client holds only it at the broker, so a broker that sends a
copy per matching subscription (NATS) still gives each role each message once (BrokerClient).

On a real drone the broker is the internal Mosquitto bridged to the ground (Listing 4.3); in the
demo and tests it may be the ground broker itself.
"""

from __future__ import annotations

import asyncio
import logging

from dronefleet.drone.battery_guard import BatteryGuard
from dronefleet.drone.config import DroneConfig
from dronefleet.drone.controller import DroneController
from dronefleet.drone.failsafe import FailSafe
from dronefleet.drone.fence_guard import FenceGuard
from dronefleet.drone.gear import GearManager
from dronefleet.drone.link_loss import LinkLossAction, LinkWatch
from dronefleet.drone.logger import DroneLogger
from dronefleet.drone.mission_worker import MissionWorker
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.url import BrokerUrl
from dronefleet.vehicle.base import FlightController
from dronefleet.vehicle.payload import Camera, Sensor

log = logging.getLogger(__name__)


class DroneApp:
    """Starts and stops every drone-side component around one flight controller."""

    def __init__(
        self,
        config: DroneConfig,
        fc: FlightController,
        broker: str | BrokerUrl,
        *,
        sensors: dict[str, Sensor] | None = None,
        camera: Camera | None = None,
    ) -> None:
        self.config = config
        self.fc = fc
        drone_id = config.drone_id

        self.client = BrokerClient(broker, f"{drone_id}-drone")
        #: The broker client of each role (one and the same).
        self.clients = {role: self.client for role in ("controller", "gear", "failsafe", "logger")}
        self.controller = DroneController(config, self.clients["controller"], fc)
        self.mission_worker = MissionWorker(self.controller)
        self.link_watch = LinkWatch(
            self.mission_worker,
            LinkLossAction(config.link_loss_action),
            config.link_loss_timeout_s,
        )
        self.gear = GearManager(
            drone_id,
            self.clients["gear"],
            fc.clock,
            gear_dir=config.gear_dir,
            sensors=sensors,
            camera=camera,
        )
        self.failsafe = FailSafe(
            drone_id,
            self.clients["failsafe"],
            fc.clock,
            battery_critical_pct=config.battery_critical_pct,
            sensor_bounds=config.sensor_bounds,
            listen_to_broker=False,  # fed below from the autopilot and the sensors (issue 12)
        )
        self.controller.add_sample_listener(self.failsafe.feed)
        self.battery_guard = BatteryGuard(
            self.mission_worker, rtl_pct=config.battery_rtl_pct, land_pct=config.battery_land_pct
        )
        self.controller.add_sample_listener(self.battery_guard.feed)
        self.fence_guard = FenceGuard(self.mission_worker)
        self.controller.add_sample_listener(self.fence_guard.feed)
        self.gear.sample_listeners.append(self.failsafe.feed)
        self.logger = (
            DroneLogger(drone_id, self.clients["logger"], config.log_dir)
            if config.log_dir is not None
            else None
        )
        if self.logger is not None:
            self.controller.add_event_listener(self.logger.log_event)

    def _connections(self) -> list[BrokerClient]:
        return list(dict.fromkeys(self.clients.values()))  # each client once, in role order

    @property
    def drone_id(self) -> str:
        return self.config.drone_id

    async def start(self, *, timeout_s: float = 15.0) -> DroneApp:
        await self.fc.connect()
        await asyncio.gather(*(c.start(timeout_s=timeout_s) for c in self._connections()))
        if self.logger is not None:
            await self.logger.start()
        await self.gear.start()
        await self.failsafe.start()
        await self.mission_worker.start()
        self.link_watch.start()
        await self.controller.start()
        log.info("drone %s up on %s", self.drone_id, self.clients["controller"].url)
        return self

    async def stop(self) -> None:
        await self.controller.stop()
        await self.link_watch.stop()
        await self.mission_worker.stop()
        await self.failsafe.stop()
        await self.gear.stop()
        if self.logger is not None:
            await self.logger.stop()
        for c in self._connections():
            await c.stop()
        await self.fc.close()

    async def __aenter__(self) -> DroneApp:
        return await self.start()

    async def __aexit__(self, *exc: object) -> None:
        await self.stop()
