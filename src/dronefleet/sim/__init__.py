"""Simulated vehicles for dronefleet: kinematics, battery, GPS, wind, gas field, camera and the
sim clock, all driven by one :class:`SimWorld` loop (docs/DESIGN.md §2, §5)."""

from dronefleet.sim.camera import SimCamera
from dronefleet.sim.clock import SimClock
from dronefleet.sim.gasfield import GasField, GasSensor, Plume
from dronefleet.sim.vehicle import SimVehicle, VehicleError
from dronefleet.sim.wind import Wind
from dronefleet.sim.world import SimWorld
from dronefleet.vehicle.kinematics import FlightLimits

__all__ = [
    "FlightLimits",
    "GasField",
    "GasSensor",
    "Plume",
    "SimCamera",
    "SimClock",
    "SimVehicle",
    "SimWorld",
    "VehicleError",
    "Wind",
]
