"""Stage 1 of the coverage pipeline: project the area into a local metric plane and back.

The plane is the exact WGS84 tangent plane (:class:`~dronefleet.geo.ned.LocalFrame`) at the
polygon's centroid, with x = east and y = north in metres, so shapely works in metres and the
distortion stays far below a centimetre for fields of a few kilometres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from shapely.geometry import Polygon
from shapely.validation import make_valid

from dronefleet.geo.ned import LocalFrame
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.coverage.spec import AreaSpec, LatLon

XY = tuple[float, float]


@dataclass(frozen=True)
class LocalProjection:
    """A local plane (x east, y north, metres) around ``origin``."""

    frame: LocalFrame

    @property
    def origin(self) -> LLA:
        return self.frame.home

    @classmethod
    def around(cls, spec: AreaSpec) -> LocalProjection:
        """The plane at the centroid of the polygon's vertices."""
        lats = [lat for lat, _ in spec.polygon]
        lons = [lon for _, lon in spec.polygon]
        return cls(LocalFrame(LLA(sum(lats) / len(lats), sum(lons) / len(lons))))

    def to_xy(self, lat: float, lon: float) -> XY:
        ned = self.frame.to_ned(LLA(lat, lon, self.origin.alt_m))
        return ned.e, ned.n

    def to_lla(self, x: float, y: float, alt_m: float = 0.0) -> LLA:
        p = self.frame.to_lla(NED(y, x, 0.0))
        return LLA(p.lat, p.lon, alt_m)

    def to_lla_many(
        self, xy: list[tuple[float, float]] | np.ndarray, alt_m: float = 0.0
    ) -> list[LLA]:
        """:meth:`to_lla` of many points at once (vectorised: a plan's waypoints)."""
        if len(xy) == 0:
            return []
        x, y = np.asarray(xy, dtype=float).T
        lat, lon = self.frame.to_lla_many(y, x)
        return LLA.many(lat, lon, alt_m)

    def ring_xy(self, ring: list[LatLon]) -> list[XY]:
        return [self.to_xy(lat, lon) for lat, lon in ring]

    def area(self, spec: AreaSpec) -> Polygon:
        """The area in the plane; a self-intersecting polygon, a hole outside it or holes that
        overlap are refused with the reason, in one sentence."""
        outer = Polygon(self.ring_xy(spec.polygon))
        holes = [Polygon(self.ring_xy(h)) for h in spec.holes]
        _check_rings(outer, holes)
        poly = Polygon(outer.exterior.coords, [h.exterior.coords for h in holes])
        if not poly.is_valid:
            fixed = make_valid(poly)
            if fixed.geom_type != "Polygon" or abs(fixed.area - poly.area) > 1e-6 * poly.area:
                raise ValueError(
                    "the area polygon is not simple (its edges cross, or a hole leaves it);"
                    " redraw it"
                )
            poly = fixed
        if poly.area <= 0:
            raise ValueError("the area polygon has no area")
        return poly


def _check_rings(outer: Polygon, holes: list[Polygon]) -> None:
    """Refuse, naming it, a ring whose edges cross, a hole not inside the polygon, or two holes
    that overlap (shapely would only say "invalid")."""
    if not outer.is_valid or outer.area <= 0:
        raise ValueError(
            "the area polygon is not simple (its edges cross, or it has no area); redraw it"
        )
    inside = outer.buffer(1e-6)
    for i, hole in enumerate(holes):
        if not hole.is_valid or hole.area <= 0:
            raise ValueError(f"hole {i} is not simple (its edges cross) or has no area; redraw it")
        if not inside.covers(hole):
            raise ValueError(f"hole {i} is not inside the area (a hole leaves it); redraw it")
        for j in range(i):
            if hole.intersection(holes[j]).area > 1e-9 * hole.area:
                raise ValueError(f"holes {j} and {i} overlap; draw them as one hole")
