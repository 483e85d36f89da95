"""A gas field to sense: background CO2 plus Gaussian plumes, and the gas (CO2) sensor reading it.

This is what the seed's collaborative-sensing experiment (section 5.4) measured with a real gas
sensor: a drone finds a concentration above the alarm level and calls others to widen the search.
The sensor implements :class:`~dronefleet.vehicle.payload.Sensor` for the Gear Manager.
"""

from __future__ import annotations

import math
import random
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import LLA
from dronefleet.vehicle.payload import Reading

if TYPE_CHECKING:
    from dronefleet.sim.vehicle import SimVehicle

#: Outdoor CO2 background (ppm).
BACKGROUND_CO2_PPM = 420.0


@dataclass(frozen=True, slots=True)
class Plume:
    """A Gaussian plume: ``peak_ppm`` above background at ``center``, falling to ~61 % at
    ``radius_m`` (one sigma, in 3-D from the centre)."""

    center: LLA
    peak_ppm: float
    radius_m: float

    def __post_init__(self) -> None:
        if not self.radius_m > 0:
            raise ValueError(f"plume radius must be positive, got {self.radius_m}")


class GasField:
    """Concentration in ppm anywhere: background plus the sum of the plumes."""

    def __init__(
        self, plumes: Iterable[Plume] = (), background_ppm: float = BACKGROUND_CO2_PPM
    ) -> None:
        self.background_ppm = background_ppm
        self.plumes: list[Plume] = list(plumes)

    def add_plume(self, center: LLA, peak_ppm: float, radius_m: float) -> Plume:
        plume = Plume(center, peak_ppm, radius_m)
        self.plumes.append(plume)
        return plume

    def concentration_ppm(self, position: LLA) -> float:
        total = self.background_ppm
        for plume in self.plumes:
            offset = lla_to_ned(position, plume.center)
            r2 = offset.n * offset.n + offset.e * offset.e + offset.d * offset.d
            total += plume.peak_ppm * math.exp(-r2 / (2.0 * plume.radius_m * plume.radius_m))
        return total


class GasSensor:
    """A gas sensor (CO2, ppm, by default) on a simulated vehicle, reading the gas field at the
    vehicle's true position. ``noise_ppm`` adds seeded Gaussian noise (one sigma) per reading.
    """

    def __init__(
        self,
        vehicle: SimVehicle,
        field: GasField,
        *,
        name: str = "CO2",
        unit: str = "ppm",
        noise_ppm: float = 0.0,
        seed: int | None = None,
    ) -> None:
        self.name = name
        self.unit = unit
        self._vehicle = vehicle
        self._field = field
        self._noise_ppm = noise_ppm
        self._rng = random.Random(seed)

    def read(self) -> Reading:
        position = self._vehicle.position_lla
        value = self._field.concentration_ppm(position)
        if self._noise_ppm > 0:
            value = max(0.0, value + self._rng.gauss(0.0, self._noise_ppm))
        return Reading(
            sensor=self.name,
            value=value,
            unit=self.unit,
            vehicle_time_s=self._vehicle.time_s,
            extra={"lat": position.lat, "lon": position.lon, "alt_m": position.alt_m},
        )
