"""The seed's areas (chapter 5) come out of the coverage pipeline with the seed's waypoints."""

from __future__ import annotations

import math

import pytest
from pydantic import ValidationError

from dronefleet.geo.distance import distance_m
from dronefleet.geo.types import LLA
from dronefleet.ground.planner.coverage import (
    AreaSpec,
    CameraSpec,
    Kind,
    collaboration_factor,
    extensibility_parameters,
    plan_area,
    rebuild,
    seed_grid_rebuild,
)
from dronefleet.ground.planner.units import units
from dronefleet.messaging.commands import parse_step


@pytest.mark.parametrize("angle", [0.0, None])
def test_the_aerial_photography_area_has_45_waypoints_in_5_columns_of_9(rect, angle):
    # 5.2.4: 32 x 64 m, waypoints 8 m apart, "the 5 columns of waypoints", 45 in all.
    spec = AreaSpec(
        polygon=rect(32, 64), spacing_m=8, grid="seed", angle_deg=angle, action="takepic"
    )
    plan = plan_area(spec)
    assert len(plan.waypoints) == 45
    assert len(plan.swaths) == 5
    # Columns along the long side (north); the tangent plane at the centroid turns it a hair.
    assert min(plan.angle_deg % 180, -plan.angle_deg % 180) < 1e-3
    assert [len(plan.mission_steps([i])) for i in range(45)] == [3] * 45
    assert plan.area_m2 == pytest.approx(2048, rel=1e-4)  # "approximately 2048 m²"
    gaps = [distance_m(a, b) for a, b in zip(plan.waypoints, plan.waypoints[1:], strict=False)]
    assert max(gaps) == pytest.approx(8, abs=0.01)


def test_the_replacement_area_has_28_waypoints_at_10_m(rect):
    # 5.3.3: "similar to the survey area", 10 m apart, 28 waypoints: 30 x 60 m -> 4 x 7.
    plan = plan_area(AreaSpec(polygon=rect(30, 60), spacing_m=10, grid="seed", angle_deg=0))
    assert len(plan.waypoints) == 28
    assert len(plan.swaths) == 4


def test_the_sensing_area_has_30_waypoints_at_7_m(rect):
    # 5.4.3: 28 x 35 m, 7 m apart, 30 waypoints, 980 m².
    spec = AreaSpec(
        polygon=rect(28, 35), spacing_m=7, grid="seed", angle_deg=0, action="read_sensors", hold_s=2
    )
    plan = plan_area(spec)
    assert len(plan.waypoints) == 30
    assert plan.area_m2 == pytest.approx(980, rel=1e-4)
    assert plan.mission_steps([0])[2] == {"command": "read_sensors", "value": 2}


def test_swaths_lie_half_a_spacing_inside_by_default(rect):
    plan = plan_area(AreaSpec(polygon=rect(32, 64), spacing_m=8))
    assert len(plan.swaths) == 4  # at 4, 12, 20, 28 m from the west edge
    xs = sorted(round(s.coords[0][0] - plan.local_polygon.bounds[0], 3) for s in plan.swaths)
    assert xs == pytest.approx([4, 12, 20, 28], abs=1e-3)
    assert len(plan.waypoints) == 36
    assert plan.uncovered_m2 == 0


def test_fly_through_survey_takes_45_pictures_without_stopping(rect):
    spec = AreaSpec(
        polygon=rect(32, 64),
        spacing_m=8,
        grid="seed",
        angle_deg=0,
        action="takepic",
        fly_through=True,
    )
    plan = plan_area(spec)
    assert plan.kinds == [Kind.SWATH_START, Kind.SWATH_END] * 5
    assert plan.photo_count == 45
    steps = plan.mission_steps()
    assert not any(s["command"] == "takepic" for s in steps)
    triggers = [s["value"] for s in steps if s["command"] == "camera_trigger"]
    # On at each swath start, off at its end; 8 intervals ending 1 m before the 64 m swath end.
    assert triggers == [pytest.approx(62 / 8, abs=1e-3), 0] * 5  # 8 intervals end 2 m short
    assert plan.trigger_distance_m == 8
    assert plan.chunk_starts() == [True, False] * 5


def test_mission_steps_are_valid_and_one_unit_per_waypoint(rect):
    for fly in (False, True):
        spec = AreaSpec(polygon=rect(40, 50), spacing_m=9, action="takepic", fly_through=fly)
        plan = plan_area(spec)
        steps = plan.mission_steps(altitude_offset_m=3)
        for step in steps:
            parse_step(step)
        assert len(units(steps)) == len(plan.waypoints)
        assert {s["altitude_delta"] for s in steps if s["command"] == "navigate"} == {13.0}


def test_camera_sets_spacing_and_trigger_like_qgroundcontrol(rect):
    camera = CameraSpec(
        sensor_width_mm=6.17,
        sensor_height_mm=4.55,
        focal_length_mm=4.5,
        image_width_px=4000,
        image_height_px=3000,
        front_overlap=0.75,
        side_overlap=0.6,
    )
    spec = AreaSpec(
        polygon=rect(60, 80), camera=camera, altitude_m=30, action="takepic", fly_through=True
    )
    across, along = 30 * 6.17 / 4.5, 30 * 4.55 / 4.5
    assert spec.line_spacing_m == pytest.approx(across * 0.4)
    assert spec.trigger_m == pytest.approx(along * 0.25)
    assert camera.gsd_cm_per_px(30) == pytest.approx(100 * across / 4000)
    plan = plan_area(spec)
    assert plan.spacing_m == pytest.approx(across * 0.4)


def test_three_clicked_vertices_make_a_parallelogram(at):
    # 5.2.2: the user clicks three vertices; the fourth is p1 + p3 - p2.
    p1, p2, p3 = at(0, 0), at(10, 30), at(50, 40)
    spec = AreaSpec.parallelogram(p1, p2, p3, spacing_m=5)
    fourth = LLA(*spec.polygon[3])
    assert distance_m(fourth, at(40, 10)) < 0.01
    plan = plan_area(spec)
    assert plan.area_m2 == pytest.approx(abs(-10 * 10 - (-30) * 40), rel=1e-4)


def test_geojson_polygon_with_a_hole(to_latlon):
    outer = [(lon, lat) for lat, lon in to_latlon([(0, 0), (60, 0), (60, 60), (0, 60), (0, 0)])]
    hole = [(lon, lat) for lat, lon in to_latlon([(20, 20), (40, 20), (40, 40), (20, 40)])]
    spec = AreaSpec.from_geojson(
        {"type": "Feature", "geometry": {"type": "Polygon", "coordinates": [outer, hole]}},
        spacing_m=6,
    )
    assert len(spec.polygon) == 4 and len(spec.holes) == 1
    assert AreaSpec.from_geojson(spec.to_geojson(), spacing_m=6) == spec
    plan = plan_area(spec)
    assert plan.area_m2 == pytest.approx(3600 - 400, rel=1e-4)
    assert plan.cells >= 3  # split round the hole
    assert AreaSpec.model_validate(spec.model_dump(mode="json")) == spec


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"spacing_m": 5, "camera": None, "fly_through": True}, "fly_through"),
        ({}, "exactly one of spacing_m or camera"),
    ],
)
def test_bad_specs_are_refused_with_the_reason(rect, fields, message):
    with pytest.raises(ValidationError, match=message):
        AreaSpec(polygon=rect(10, 10), **fields)


def test_a_crossed_polygon_is_refused(to_latlon):
    bow = to_latlon([(0, 0), (20, 20), (20, 0), (0, 20)])
    with pytest.raises(ValueError, match="not simple"):
        plan_area(AreaSpec(polygon=bow, spacing_m=5))


def test_rebuild_keeps_shape_orientation_and_spacing_and_grows_the_area(to_latlon, at):
    spec = AreaSpec(
        polygon=to_latlon([(0, 0), (50, 10), (40, 45), (5, 30)]),
        spacing_m=6,
        action="read_sensors",
        hold_s=2,
    )
    before = plan_area(spec)
    centre = at(200, -100)
    grown = rebuild(spec, centre, collaboration_factor(2))
    after = plan_area(grown)
    assert after.area_m2 == pytest.approx(2 * before.area_m2, rel=1e-4)
    assert after.angle_deg == pytest.approx(before.angle_deg, abs=1e-3)
    assert after.spacing_m == before.spacing_m and grown.action == spec.action
    c = after.local_polygon.centroid
    assert math.hypot(c.x, c.y) < 20  # the new plane is near the new centre...
    centroid_lla = after.origin
    assert distance_m(LLA(centroid_lla.lat, centroid_lla.lon), centre) < 20


def test_seed_grid_rebuild_reproduces_56_waypoints_and_2058_m2(rect, at):
    # 5.4.4: two drones join: +50% each; the seed's grid gives 56 waypoints, 2058 m², +110%.
    spec = AreaSpec(
        polygon=rect(28, 35), spacing_m=7, grid="seed", angle_deg=0, action="read_sensors", hold_s=2
    )
    grown = seed_grid_rebuild(spec, at(14, 17), collaboration_factor(2))
    plan = plan_area(grown)
    assert len(plan.waypoints) == 56
    assert plan.area_m2 == pytest.approx(2058, rel=1e-4)
    assert round(plan.area_m2 / 980 - 1, 2) == 1.10
    exact = plan_area(rebuild(spec, at(14, 17), 2.0))
    assert exact.area_m2 == pytest.approx(1960, rel=1e-4)


def test_extensibility_parameters_are_the_seeds(rect):
    spec = AreaSpec(polygon=rect(28, 35), spacing_m=7, action="read_sensors", hold_s=2)
    params = extensibility_parameters(spec)
    assert params["intermediate_action"] == {"command": "read_sensors", "value": 2}
    assert params["step_distance"] == 7
    v, w = params["vectors"]["v"], params["vectors"]["w"]
    assert math.hypot(v["n"], v["e"]) == pytest.approx(35, abs=0.01)
    assert math.hypot(w["n"], w["e"]) == pytest.approx(28, abs=0.01)


def test_an_area_too_big_for_its_spacing_is_refused_with_the_reason(rect):
    with pytest.raises(ValueError, match="widen the spacing"):
        plan_area(AreaSpec(polygon=rect(2000, 2000), spacing_m=5))
    with pytest.raises(ValidationError):
        AreaSpec(polygon=rect(20, 20), spacing_m=float("nan"))
