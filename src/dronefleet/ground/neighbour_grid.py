"""Which drones are near which: a grid of cubes on the Earth-centred frame (issue 27).

The separation monitor (ground/separation_monitor.py) compares each message of a drone in the
air with the drones in the air in the 27 cubes around it. Working out those neighbours for each
message (a set built from 27 lookups, then sorted) was a third of the monitor's cost at 5 Hz per
drone. Drones seldom change cube (a 150 m cube takes 15 s to cross at 10 m/s), so the neighbours
of a cube are kept, sorted, until a drone enters or leaves one of the 27 cubes around it: a
message then costs one lookup.

A cube is ``(x, y, z)`` integers: the position on the Earth-centred frame divided by the cube's
side (:func:`cube_of`): one scale everywhere, so neighbours are neighbours at any latitude and
across the antimeridian. A spatial index from a library (an R-tree: ``rtree``, shapely's
``STRtree``) answers "what is within a box" in O(log n) per query but is rebuilt or updated per
move; at a few neighbours per drone a dictionary of cubes is cheaper, and needs no dependency.
"""

from __future__ import annotations

import math

Cube = tuple[int, int, int]

_EARTH_R_M = 6_371_000.0
_AROUND = tuple((dx, dy, dz) for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1))


def cube_of(lat: float, lon: float, alt_m: float, side_m: float) -> Cube:
    """The cube of side ``side_m`` holding the position (degrees, metres above the sphere)."""
    la, lo = math.radians(lat), math.radians(lon)
    r = _EARTH_R_M + alt_m
    flat = r * math.cos(la)
    x, y, z = flat * math.cos(lo), flat * math.sin(lo), r * math.sin(la)
    return (math.floor(x / side_m), math.floor(y / side_m), math.floor(z / side_m))


class NeighbourGrid:
    """Drones by cube; :meth:`around` the drones of the 27 cubes around one, kept sorted."""

    def __init__(self) -> None:
        self._members: dict[Cube, set[str]] = {}
        self._cube_of: dict[str, Cube] = {}
        #: The sorted drones of the 27 cubes around a cube, kept until one of them changes.
        self._around: dict[Cube, tuple[str, ...]] = {}

    def place(self, drone_id: str, cube: Cube | None) -> None:
        """``drone_id`` is now in ``cube`` (None: in no cube, e.g. on the ground)."""
        old = self._cube_of.get(drone_id)
        if old == cube:
            return
        if old is not None:
            members = self._members[old]
            members.discard(drone_id)
            if not members:
                del self._members[old]
            self._changed(old)
        if cube is None:
            del self._cube_of[drone_id]
            return
        self._members.setdefault(cube, set()).add(drone_id)
        self._cube_of[drone_id] = cube
        self._changed(cube)

    def around(self, drone_id: str) -> tuple[str, ...]:
        """The drones in the 27 cubes around ``drone_id``'s, itself included, sorted; () when
        it is in no cube."""
        cube = self._cube_of.get(drone_id)
        if cube is None:
            return ()
        kept = self._around.get(cube)
        if kept is None:
            x, y, z = cube
            found: set[str] = set()
            for dx, dy, dz in _AROUND:
                members = self._members.get((x + dx, y + dy, z + dz))
                if members:
                    found |= members
            kept = self._around[cube] = tuple(sorted(found))
        return kept

    def clear(self) -> None:
        self._members.clear()
        self._cube_of.clear()
        self._around.clear()

    def _changed(self, cube: Cube) -> None:
        """``cube``'s drones changed: forget what the 27 cubes around it keep."""
        x, y, z = cube
        around = self._around
        for dx, dy, dz in _AROUND:
            around.pop((x + dx, y + dy, z + dz), None)
