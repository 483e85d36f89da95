"""The bench's Fields2Cover fields (issue 30) as AreaSpecs, and coverage measured as the issue did.

The fields are ``bench/data/f2c_reference.json``'s (outlines in east, north metres from its
origin). The bench builds its specs the same way (``bench/coverage_vs_f2c.py``'s ``spec_of``);
the tests do not import the bench, which is not on their path.
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Point

from dronefleet.geo.ned import LocalFrame
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.coverage import AreaSpec, CoveragePlan

DATA = Path(__file__).parents[2] / "bench" / "data" / "f2c_reference.json"
DOC: dict[str, Any] = json.loads(DATA.read_text())
FIELDS: dict[str, dict[str, Any]] = {f["name"]: f for f in DOC["fields"]}
FRAME = LocalFrame(LLA(*DOC["origin_lat_lon"]))
SPACING: float = DOC["spacing_m"]


def ring(points: Iterable[Sequence[float]]) -> list[tuple[float, float]]:
    """(east, north) metres from the fields' origin -> [lat, lon] pairs."""
    return [(p.lat, p.lon) for p in (FRAME.to_lla(NED(n, e)) for e, n in points)]


def spec(name: str, *, fly: bool = False, target: float = 100.0, **fields: Any) -> AreaSpec:
    """The field called ``name``, photographed at the bench's spacing; ``fields`` go to AreaSpec."""
    f = FIELDS[name]
    return AreaSpec(
        polygon=ring(f["outline_m"]),
        holes=[ring(h) for h in f["holes_m"]],
        spacing_m=SPACING,
        action="takepic",
        fly_through=fly,
        coverage_target_pct=target,
        **fields,
    )


def coverage_pct(plan: CoveragePlan) -> float:
    """Area within half a spacing of the path over the field's area (each leg buffered)."""
    xy = np.array([p.xy for p in plan.points])
    legs = [(a, b) for a, b in itertools.pairwise(xy.tolist()) if a != b]
    parts = shapely.buffer(shapely.linestrings(legs), plan.spacing_m / 2, quad_segs=16)
    band = shapely.union_all([*parts, Point(xy[0]).buffer(plan.spacing_m / 2)])
    area = plan.local_polygon
    return 100.0 * area.intersection(band).area / area.area


def legs_of(plan: CoveragePlan) -> np.ndarray:
    """The plan's legs of non-zero length, as shapely linestrings."""
    return shapely.linestrings(
        [[a.xy, b.xy] for a, b in itertools.pairwise(plan.points) if a.xy != b.xy]
    )
