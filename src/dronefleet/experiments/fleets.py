"""Simulated drones behind any flight-controller backend, all in ONE world (issue 6).

The experiments fly through the real components down to the Flight Controller Interface; this
module chooses what is below it, per drone:

- ``sim``: the in-process :class:`~dronefleet.sim.flight_controller.SimFlightController`;
- ``mavlink``: the MAVLink backend over UDP to a :class:`~dronefleet.sim.mavlink.MavlinkSimServer`
  vehicle, payload through the autopilot (NAMED_VALUE_FLOAT gas, camera trigger);
- ``uavtalk``: the UAVTalk backend over TCP to a :class:`~dronefleet.sim.uavtalk.UAVTalkServer`
  vehicle, payload on the companion computer as in the seed (Figure 3.5);
- ``mixed``: the three in turn (:data:`MIXED_ORDER`), so six drones are three MAVLink, one
  UAVTalk and two in-process.

Every vehicle lives in the same :class:`~dronefleet.sim.world.SimWorld`, so all of them share one
clock. The autopilots' own clocks (MAVLink ``time_boot_ms``, UAVTalk ``SystemStats.FlightTime``)
count from the world's zero — as if every autopilot booted when the world did — so a drone's
vehicle seconds, whatever its backend, are comparable with every other's and with the world's.
"""

from __future__ import annotations

import asyncio
import enum
import itertools
import logging
from typing import Any

from dronefleet.drone.app import DroneApp
from dronefleet.drone.config import DroneConfig
from dronefleet.drone.fc import mavlink as mavlink_fc
from dronefleet.drone.fc import uavtalk as uavtalk_fc
from dronefleet.geo.types import LLA
from dronefleet.messaging.url import BrokerUrl
from dronefleet.sim.camera import SimCamera
from dronefleet.sim.gasfield import GasSensor
from dronefleet.sim.mavlink import MavlinkSimServer
from dronefleet.sim.uavtalk import UAVTalkServer
from dronefleet.sim.vehicle import SimVehicle
from dronefleet.simfleet import SimFleet

log = logging.getLogger(__name__)


class FcBackend(enum.StrEnum):
    SIM = "sim"
    MAVLINK = "mavlink"
    UAVTALK = "uavtalk"
    MIXED = "mixed"


#: The backend of the n-th drone of a ``mixed`` fleet: with three drones one of each; with six,
#: three MAVLink, one UAVTalk and two in-process (issue 6, Must show 4).
MIXED_ORDER = (
    FcBackend.MAVLINK,
    FcBackend.UAVTALK,
    FcBackend.SIM,
    FcBackend.MAVLINK,
    FcBackend.SIM,
    FcBackend.MAVLINK,
)
#: Wall seconds a drone gets to stop before the fleet moves on.
STOP_TIMEOUT_S = 5.0


class ProtocolFleet(SimFleet):
    """A :class:`SimFleet` whose drones reach their vehicles through ``backend``."""

    def __init__(self, *, backend: FcBackend | str = FcBackend.SIM, **options: Any) -> None:
        super().__init__(**options)
        self.backend = FcBackend(backend)
        self.backends: dict[str, FcBackend] = {}  # drone id -> backend it flies on
        self._vehicles: dict[str, SimVehicle] = {}
        self._order = itertools.cycle(MIXED_ORDER)
        self._mavlink: MavlinkSimServer | None = None
        self._uavtalk: list[UAVTalkServer] = []

    def vehicle(self, drone_id: str) -> SimVehicle:
        """The simulated vehicle under ``drone_id``, whatever the protocol in between."""
        return self._vehicles[drone_id]

    def next_backend(self) -> FcBackend:
        return next(self._order) if self.backend is FcBackend.MIXED else self.backend

    async def add_drone(
        self,
        config: DroneConfig,
        broker: str | BrokerUrl,
        *,
        home: LLA,
        battery_pct: float = 100.0,
        start: bool = True,
        backend: FcBackend | str | None = None,
        **vehicle_params: Any,
    ) -> DroneApp:
        """A vehicle at ``home`` and the drone software on it, over ``backend`` (default: the
        fleet's, or the next of :data:`MIXED_ORDER`)."""
        kind = FcBackend(backend) if backend is not None else self.next_backend()
        if kind is FcBackend.MIXED:
            raise ValueError("a single drone needs one backend, not 'mixed'")
        if kind is FcBackend.SIM:
            app = await super().add_drone(
                config, broker, home=home, battery_pct=battery_pct, start=start, **vehicle_params
            )
            self._vehicles[config.drone_id] = self.world.vehicles[config.drone_id]
        else:
            vehicle_params["initial_charge_pct"] = battery_pct
            opener = self._open_mavlink if kind is FcBackend.MAVLINK else self._open_uavtalk
            vehicle, fc, sensors, camera = await opener(config, home, vehicle_params)
            self._vehicles[config.drone_id] = vehicle
            app = await self.launch(config, fc, broker, sensors=sensors, camera=camera, start=start)
        self.backends[config.drone_id] = kind
        log.info("drone %s flies over %s", config.drone_id, kind.value)
        return app

    async def _open_mavlink(self, config: DroneConfig, home: LLA, params: dict[str, Any]):
        if self._mavlink is None:
            self._mavlink = MavlinkSimServer(self.world)
        server = self._mavlink
        endpoint = server.add_vehicle(home, port=free_udp_port(), **params)
        # time_boot_ms from the world's zero: the drone's clock reads world seconds.
        endpoint.copter.boot_epoch_s = 0.0
        if len(server.endpoints) == 1:
            await server.start()
        else:
            await endpoint.start()
        fc = await mavlink_fc.open_flight_controller(f"udpout:127.0.0.1:{endpoint.port}")
        sensors, camera = mavlink_fc.payload(fc)
        return endpoint.copter.vehicle, fc, sensors, camera

    async def _open_uavtalk(self, config: DroneConfig, home: LLA, params: dict[str, Any]):
        vehicle = self.world.add_vehicle(config.drone_id, home, **params)
        server = UAVTalkServer(self.world, [config.drone_id])
        await server.start()
        self._uavtalk.append(server)
        fc = await uavtalk_fc.open_flight_controller(server.endpoints[config.drone_id])
        pictures = config.log_dir / "pictures" if config.log_dir is not None else None
        sensors = {"CO2": GasSensor(vehicle, self.gas_field)}
        return vehicle, fc, sensors, SimCamera(vehicle, pictures)

    async def stop(self) -> None:
        for drone_id, app in list(self.apps.items()):
            try:  # one drone that cannot close its link must not keep the others flying
                async with asyncio.timeout(STOP_TIMEOUT_S):
                    await app.stop()
            except Exception as exc:
                log.warning("drone %s did not stop cleanly: %r", drone_id, exc)
        self.apps.clear()
        for server in self._uavtalk:
            await server.stop()
        self._uavtalk.clear()
        if self._mavlink is not None:
            await self._mavlink.stop()  # also stops the world
            self._mavlink = None
        await super().stop()


def free_udp_port() -> int:
    """A loopback UDP port nobody is bound to right now (drawn as messaging/embedded.py says)."""
    import socket

    from dronefleet.messaging.embedded import free_port

    return free_port(kind=socket.SOCK_DGRAM)
