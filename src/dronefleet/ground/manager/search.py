"""The map pages' search box (issue 14): ``GET /api/v1/search?q=`` → places to centre on.

What was typed is read, in order, as coordinates (decimal or DMS, :mod:`dronefleet.geo.
coordinates_text`), a drone's id (where it is now), a mission's name or id (its area), and
otherwise an address, through the ground's geocoder (``--geocoder``) when it has one. One route
rather than parsing in the page: the rules are tested once, here, and every page gets the same.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Query, Request
from pydantic import BaseModel

from dronefleet.errors import DronefleetError, InvalidInput
from dronefleet.geo.coordinates_text import CoordinateError, parse_coordinates
from dronefleet.ground.manager.context import Viewer, ctx_of
from dronefleet.ground.manager.errors import answers
from dronefleet.ground.manager.geocoder import Geocoder, Place, PlaceKind

router = APIRouter(prefix="/api/v1", tags=["web"], responses=answers(401, 403, 422))

NO_GEOCODER = "addresses need a geocoder: start the ground with --geocoder URL"
MAX_MATCHES = 8


class SearchAnswer(BaseModel):
    query: str
    places: list[Place]
    note: str | None = None  # why nothing (or only part) was found


@router.get(
    "/search",
    summary="Places for the map: coordinates, a drone, a mission or (with --geocoder) an address",
    responses=answers(503, 504),
)
async def search(
    request: Request, who: Viewer, q: str = Query(min_length=1, max_length=200)
) -> SearchAnswer:
    text = " ".join(q.split())
    try:
        point = parse_coordinates(text)
    except CoordinateError as exc:
        raise InvalidInput(f"{text!r}: {exc}") from None
    if point is not None:
        lat, lon = point
        label = f"{lat:.6f}, {lon:.6f}"
        return SearchAnswer(
            query=text, places=[Place(kind=PlaceKind.COORDINATES, label=label, lat=lat, lon=lon)]
        )
    places = await _drones(request, text) + _missions(request, text)
    if places:
        return SearchAnswer(query=text, places=places[:MAX_MATCHES])
    geocoder: Geocoder | None = getattr(request.app.state, "geocoder", None)
    if geocoder is None:
        return SearchAnswer(query=text, places=[], note=NO_GEOCODER)
    found = await geocoder.search(text)
    return SearchAnswer(query=text, places=found, note=None if found else "no such address")


async def _drones(request: Request, text: str) -> list[Place]:
    """Drones whose id holds ``text`` (any case), where they are; the exact id first."""
    try:
        fleet = await ctx_of(request).gateway.fleet()
    except DronefleetError:
        return []  # the Drone Identifier is away: the search goes on without drones
    needle = text.lower()
    found = []
    for drone in fleet:
        drone_id, where = str(drone.get("drone_id", "")), drone.get("position") or {}
        if needle not in drone_id.lower() or not _point(where):
            continue
        place = Place(
            kind=PlaceKind.DRONE, label=f"drone {drone_id}", lat=where["lat"], lon=where["lon"]
        )
        found.append((drone_id.lower() != needle, drone_id, place))
    return [place for *_, place in sorted(found, key=lambda f: (f[0], f[1]))]


def _missions(request: Request, text: str) -> list[Place]:
    """Missions whose name or id holds ``text``: the box around their area and waypoints."""
    planner = getattr(request.app.state, "planner", None)
    if planner is None:
        return []
    needle = text.lower()
    found = []
    for record in sorted(planner.missions.values(), key=lambda r: -r.created_at):
        if needle not in record.name.lower() and needle not in record.mission_id.lower():
            continue
        points = [(float(s["lat"]), float(s["lon"])) for s in record.work if _point(s)]
        if record.area is not None:
            points += [(float(p[0]), float(p[1])) for p in record.area.polygon]
        if not points:
            continue
        lats, lons = [p[0] for p in points], [p[1] for p in points]
        south, west, north, east = min(lats), min(lons), max(lats), max(lons)
        label = f"mission {record.name or record.mission_id} ({record.mission_id})"
        found.append(
            Place(
                kind=PlaceKind.MISSION,
                label=label,
                lat=(south + north) / 2,
                lon=(west + east) / 2,
                bounds=[south, west, north, east],
            )
        )
    return found


def _point(data: Any) -> bool:
    return (
        isinstance(data, dict)
        and isinstance(data.get("lat"), int | float)
        and isinstance(data.get("lon"), int | float)
    )
