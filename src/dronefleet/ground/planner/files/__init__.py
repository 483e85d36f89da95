"""Mission files (issue 14): what other ground stations and map tools write, in and out of the
Mission Planner (seed 4.2.4's planner input, from files instead of clicks).

- :mod:`.plan`: QGroundControl's ``.plan`` (JSON: mission items, geofence, rally points), read
  and written; what QGroundControl, MAVSDK and Mission Planner's QGC import read.
- :mod:`.kml`: a field boundary drawn in Google Earth (a KML Polygon), read.
- :mod:`.imported`: what an import gives: a mission request the planner takes as it is
  (``POST /api/v1/missions``), with the warnings about what could not be carried over.
- :mod:`.api`: the REST routes (``POST /api/v1/missions/import``, ``GET .../{id}/plan``,
  ``POST /api/v1/missions/preview/plan``).

Files are untrusted input: each is parsed in the planning worker (ground/planner/worker.py), so
neither a large file nor a parser fault touches the event loop that serves drones, and every
refusal is an :class:`~dronefleet.errors.InvalidInput` (422) with the reason.
"""
