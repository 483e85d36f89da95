"""Extensibility (seed 4.2.4, Figure 4.28): rebuild an area task with a new centre, larger.

The seed kept ``intermediate_action``, vectors v and w and ``step_distance`` so that a mission
could be rebuilt "with the exact same shape, a new center and a higher area coverage" when a
collaboration alarm came in (5.4: +50% area per joining drone). Here the stored
:class:`~.spec.AreaSpec` is those parameters for any polygon:

* :func:`rebuild` — same shape, orientation and spacing, scaled by sqrt(area_factor) about the
  new centre (the area grows by exactly ``area_factor``);
* :func:`seed_grid_rebuild` — the seed's own rule for its parallelograms, kept for the baseline:
  each side scaled by sqrt(area_factor) and rounded to a whole number of spacings (5.4.4: 28 x 35
  m at 7 m, two drones joining -> 42 x 49 m, 56 waypoints, 2058 m², +110%).
"""

from __future__ import annotations

import math
from typing import Any

from shapely.geometry import Polygon

from dronefleet.geo.ned import LocalFrame
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.coverage.pipeline import plan_area
from dronefleet.ground.planner.coverage.project import LocalProjection
from dronefleet.ground.planner.coverage.spec import Action, AreaSpec, Grid, LatLon


def collaboration_factor(joining_drones: int) -> float:
    """The seed's rule: the area grows by 50% for each drone that joins."""
    return 1.0 + 0.5 * joining_drones


def _check(area_factor: float) -> None:
    if not area_factor > 0:
        raise ValueError(f"area_factor must be positive, got {area_factor}")


def rebuild(spec: AreaSpec, new_center: LLA, area_factor: float) -> AreaSpec:
    """``spec``'s shape scaled by sqrt(``area_factor``) about ``new_center``; same spacing."""
    _check(area_factor)
    projection = LocalProjection.around(spec)
    area = projection.area(spec)
    cx, cy = area.centroid.x, area.centroid.y
    k = math.sqrt(area_factor)
    target = LocalFrame(LLA(new_center.lat, new_center.lon))

    def move(ring: list[LatLon]) -> list[LatLon]:
        out = []
        for x, y in projection.ring_xy(ring):
            p = target.to_lla(NED((y - cy) * k, (x - cx) * k))
            out.append((p.lat, p.lon))
        return out

    angle = spec.angle_deg
    if angle is None:  # freeze the orientation the original was flown at
        angle = plan_area(spec).angle_deg
    update = {"polygon": move(spec.polygon), "holes": [move(h) for h in spec.holes]}
    return _updated(spec, {**update, "angle_deg": angle})


def _updated(spec: AreaSpec, update: dict[str, Any]) -> AreaSpec:
    """A validated copy (model_copy would skip validation, leaving plain strings for enums)."""
    return AreaSpec.model_validate({**spec.model_dump(), **update})


def _sides(spec: AreaSpec) -> tuple[LocalProjection, tuple[float, float], tuple[float, float]]:
    if len(spec.polygon) != 4 or spec.holes:
        raise ValueError("the seed's grid rebuild needs a parallelogram (4 vertices, no holes)")
    projection = LocalProjection.around(spec)
    p1, p2, p3 = (projection.to_xy(*p) for p in spec.polygon[:3])
    v = (p1[0] - p2[0], p1[1] - p2[1])
    w = (p3[0] - p2[0], p3[1] - p2[1])
    return projection, v, w


def seed_grid_rebuild(spec: AreaSpec, new_center: LLA, area_factor: float) -> AreaSpec:
    """The seed's rebuild: sides scaled by sqrt(factor), rounded to whole spacings, seed grid."""
    _check(area_factor)
    _, v, w = _sides(spec)
    s, k = spec.line_spacing_m, math.sqrt(area_factor)

    def whole(vec: tuple[float, float]) -> tuple[float, float]:
        length = math.hypot(*vec)
        n = max(1, math.floor(length * k / s + 0.5))
        return vec[0] / length * n * s, vec[1] / length * n * s

    v2, w2 = whole(v), whole(w)
    frame = LocalFrame(LLA(new_center.lat, new_center.lon))
    x2, y2 = -(v2[0] + w2[0]) / 2.0, -(v2[1] + w2[1]) / 2.0  # p2 relative to the centre

    def at(x: float, y: float) -> LatLon:
        p = frame.to_lla(NED(y, x))
        return p.lat, p.lon

    ring = [
        at(x2 + v2[0], y2 + v2[1]),
        at(x2, y2),
        at(x2 + w2[0], y2 + w2[1]),
        at(x2 + v2[0] + w2[0], y2 + v2[1] + w2[1]),
    ]
    return _updated(spec, {"polygon": ring, "grid": Grid.SEED})


def extensibility_parameters(spec: AreaSpec) -> dict[str, Any]:
    """The seed's parameters (Figure 4.25/4.28) for a parallelogram spec: action, v, w, step."""
    _, v, w = _sides(spec)
    action: dict[str, Any] | None = None
    if spec.action == Action.TAKEPIC:
        action = {"command": "takepic"}
    elif spec.action == Action.READ_SENSORS:
        action = {"command": "read_sensors", "value": spec.hold_s}
    return {
        "intermediate_action": action,
        "vectors": {"v": {"n": v[1], "e": v[0]}, "w": {"n": w[1], "e": w[0]}},
        "step_distance": spec.line_spacing_m,
    }


def area_m2(spec: AreaSpec) -> float:
    """The area of ``spec`` in square metres."""
    poly: Polygon = LocalProjection.around(spec).area(spec)
    return float(poly.area)
