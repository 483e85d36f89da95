"""A simulated sensor on the companion computer of an autopilot's vehicle (issue 28, item 6).

``dronefleet drone --fc mavlink|uavtalk --plume LAT,LON,PEAK,RADIUS`` gives the drone a gas
sensor that reads a simulated gas field at the vehicle's position as its autopilot reports it
(:meth:`~dronefleet.vehicle.base.FlightController.position`), so the Fail-safe's sensor bounds, the
alarms and the planner's collaborative extension work on ArduPilot SITL, PX4 or our own
simulator served over MAVLink or UAVTalk, without an outside script sending ``NAMED_VALUE_FLOAT
"CO2"``. The field itself comes from the command line (the CLI composes it from
:mod:`dronefleet.sim.gasfield`: the drone layer does not import the simulator).

Every reading says it is simulated (``extra["simulated"] is True`` and where it comes from,
``extra["source"]``), in the gear ``reading`` reply like any other field of the reading.

Heights: an autopilot's altitude is above mean sea level (ArduPilot SITL's default field is
584 m up) while a ``--plume`` gives no altitude, so the field is read at the vehicle's height above
its home: a plume's centre is on the ground at home, wherever on Earth the autopilot is.
"""

from __future__ import annotations

from collections.abc import Callable

from dronefleet.geo.types import LLA
from dronefleet.vehicle.base import FlightController
from dronefleet.vehicle.payload import Reading


class SimulatedSensor:
    """A :class:`~dronefleet.vehicle.payload.Sensor` reading ``field`` where the vehicle is.

    ``field`` is given the vehicle's latitude and longitude and its height above home (as
    ``alt_m``); it returns the value in ``unit``. ``source`` says where the field came from
    (``--plume``)."""

    def __init__(
        self,
        fc: FlightController,
        field: Callable[[LLA], float],
        *,
        name: str = "CO2",
        unit: str = "ppm",
        source: str = "--plume",
    ) -> None:
        self.name = name
        self.unit = unit
        self.source = source
        self._fc = fc
        self._field = field

    def read(self) -> Reading:
        here, home = self._fc.position(), self._fc.home()
        value = self._field(LLA(here.lat, here.lon, here.alt_m - home.alt_m))
        return Reading(
            sensor=self.name,
            value=value,
            unit=self.unit,
            vehicle_time_s=self._fc.clock.now(),
            extra={
                "lat": here.lat,
                "lon": here.lon,
                "alt_m": here.alt_m,
                "simulated": True,
                "source": self.source,
            },
        )
