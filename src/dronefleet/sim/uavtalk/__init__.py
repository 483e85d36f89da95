"""Our simulator speaking the seed's protocol: SimVehicles served as dRonin flight controllers
over UAVTalk on TCP, so the ``uavtalk`` backend is exercised over real bytes (issue 6).

:class:`UAVTalkServer` serves a :class:`~dronefleet.sim.world.SimWorld`; :mod:`.cli` runs it from
the command line (``python -m dronefleet.sim.uavtalk``).
"""

from dronefleet.sim.uavtalk.server import UAVTalkServer
from dronefleet.sim.uavtalk.vehicle_objects import VehicleObjects

__all__ = ["UAVTalkServer", "VehicleObjects"]
