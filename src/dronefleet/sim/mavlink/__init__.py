"""Our simulator over MAVLink: simulated vehicles that behave like ArduPilot Copter on the wire,
so the drone software (and any MAVLink ground station) flies them through real bytes.

:mod:`.copter` (modes) and :mod:`.auto` (missions on board) over a SimVehicle; :mod:`.endpoint`
(UDP, dispatch), :mod:`.handlers` (commands), :mod:`.transfer` (mission protocol),
:mod:`.streams` (telemetry), :mod:`.params` (parameters); :mod:`.server` (many vehicles).
"""

from dronefleet.sim.mavlink.copter import SimCopter
from dronefleet.sim.mavlink.endpoint import VehicleEndpoint
from dronefleet.sim.mavlink.server import MavlinkSimServer, fleet_server

__all__ = ["MavlinkSimServer", "SimCopter", "VehicleEndpoint", "fleet_server"]
