"""Geography: LLA <-> local NED, distances, polygons, areas <-> waypoints."""

from dronefleet.geo.types import LLA, NED

__all__ = ["LLA", "NED"]
