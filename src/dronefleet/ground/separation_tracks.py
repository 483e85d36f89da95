"""A drone's track as the separation monitor keeps it, and the arithmetic of a pair of tracks.

The monitor (ground/separation_monitor.py) keeps each drone's latest position, velocity and
course (:class:`Track`, from its telemetry: :func:`track_of`) and, for each message of a drone in
the air, works out where each neighbour is from it now (:func:`origin` once per message,
:func:`offset` once per neighbour: both moved on by their velocity for at most
:data:`MAX_EXTRAPOLATION_S`) and whether the pair is too far apart for their courses to matter
(:func:`out_of_reach`). Positions are compared in a local flat-earth approximation (metres per
degree at the pair's latitude): within centimetres of WGS84 at the few hundred metres where it
matters, with no allocation per pair.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from dronefleet.ground.courses import Course, course_to
from dronefleet.ground.neighbour_grid import Cube, cube_of
from dronefleet.ground.planner.separation import HORIZONTAL_M, VERTICAL_M
from dronefleet.messaging.status import Telemetry

#: Positions are moved on by their velocity at most this long (old telemetry is not a forecast).
MAX_EXTRAPOLATION_S = 1.0
#: The neighbour grid's cube side (ground/neighbour_grid.py): two drones more than a cube apart
#: cannot breach within the horizon unless they close faster than ``CELL_M / HORIZON_S``.
CELL_M = 150.0
_M_PER_DEG = 111_320.0


#: A course that holds still: the default of a track heard from a heartbeat only.
_STILL = Course((0.0, 0.0, 0.0))


@dataclass(slots=True)
class Track:
    """Slots: a track per message of every drone (issue 27: 15,000 a second on a replica of a
    10,000-drone deployment) costs no ``__dict__`` to build or for the collector to walk."""

    lat: float
    lon: float
    alt_m: float
    vn: float = 0.0
    ve: float = 0.0
    vd: float = 0.0
    in_air: bool = False
    seen_s: float = 0.0  # monotonic() when heard
    vehicle_time_s: float = 0.0
    telemetry_s: float = -math.inf  # monotonic() of its last telemetry
    course: Course = _STILL  # what it flies next (Course is frozen: shared safely)
    #: The fastest it may move on its course, over the ground and up or down (m/s).
    flat_mps: float = 0.0
    climb_mps: float = 0.0


def _course(f: dict[str, float]) -> Course:
    """What a drone whose telemetry fields are ``f`` is expected to fly next: on to the goal
    they name, if any (ground/courses.py). Worked out once per message, not once per pair."""
    vel = (f.get("vn", 0.0), f.get("ve", 0.0), -f.get("vd", 0.0))
    if "goal_lat" not in f or "goal_lon" not in f or "goal_alt_m" not in f:
        return Course(vel)
    east_m_per_deg = _M_PER_DEG * math.cos(math.radians(f["lat"]))
    to_goal = (
        (f["goal_lat"] - f["lat"]) * _M_PER_DEG,
        _dlon(f["lon"], f["goal_lon"]) * east_m_per_deg,
        f["goal_alt_m"] - f["alt_m"],
    )
    return course_to(vel, to_goal)


def track_of(msg: Telemetry, seen_s: float) -> Track | None:
    """The track ``msg`` says, heard at ``seen_s`` (monotonic); None without a position. Built
    in one call (no default course made to be replaced): it runs for every message."""
    f = msg.fields
    if "lat" not in f or "lon" not in f or "alt_m" not in f:
        return None
    course = _course(f)
    vel = course.vel
    return Track(
        f["lat"], f["lon"], f["alt_m"], f.get("vn", 0.0), f.get("ve", 0.0), f.get("vd", 0.0),
        bool(f.get("in_air", 0.0)), seen_s, msg.vehicle_time_s, seen_s, course,
        math.hypot(vel[0], vel[1]), abs(vel[2]),
    )  # fmt: skip


def relative(a: Track, b: Track, now: float) -> tuple[float, float, float]:
    """Where ``b`` is from ``a`` (n, e, up metres), now."""
    return offset(origin(a, now), b, now)


#: A track as the origin of :func:`offset`: metres per degree east at its latitude, its
#: latitude and longitude, and how far its velocity has moved it on (n, e) and its height.
Origin = tuple[float, float, float, float, float, float]


def origin(a: Track, now: float) -> Origin:
    """What :func:`offset` needs of ``a``, worked out once for all its neighbours."""
    da = age(a, now)
    east_m_per_deg = _M_PER_DEG * math.cos(math.radians(a.lat))
    return east_m_per_deg, a.lat, a.lon, a.vn * da, a.ve * da, a.alt_m - a.vd * da


def offset(of: Origin, b: Track, now: float) -> tuple[float, float, float]:
    """Where ``b`` is from the track ``of`` was made of (n, e, up metres), now."""
    east_m_per_deg, lat, lon, an, ae, au = of
    db = age(b, now)
    n = (b.lat - lat) * _M_PER_DEG + b.vn * db - an
    e = _dlon(lon, b.lon) * east_m_per_deg + b.ve * db - ae
    return n, e, (b.alt_m - b.vd * db) - au


def out_of_reach(a: Track, b: Track, flat: float, up: float, horizon_s: float) -> bool:
    """Whether ``a`` and ``b``, ``flat`` metres apart over the ground and ``up`` metres apart
    vertically, are too far apart to come within the minima in ``horizon_s`` at any speed their
    courses allow (each at most its own, so they close at most at the sum): most neighbours are,
    and the courses are then not worked out (issue 27: it was the monitor's largest cost per
    message, on drones hovering 200 m apart)."""
    if flat - (a.flat_mps + b.flat_mps) * horizon_s >= HORIZONTAL_M:
        return True
    return abs(up) - (a.climb_mps + b.climb_mps) * horizon_s >= VERTICAL_M


def age(track: Track, now: float) -> float:
    """How far its last position is moved on by its velocity (bounded: see MAX_EXTRAPOLATION_S)."""
    return min(max(now - track.seen_s, 0.0), MAX_EXTRAPOLATION_S)


def cube(track: Track) -> Cube:
    """The neighbour grid's cube (:data:`CELL_M`) of ``track``'s position."""
    return cube_of(track.lat, track.lon, track.alt_m, CELL_M)


def _dlon(from_deg: float, to_deg: float) -> float:
    """Degrees of longitude from one to the other the short way (across the antimeridian too)."""
    return (to_deg - from_deg + 180.0) % 360.0 - 180.0
