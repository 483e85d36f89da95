"""Mission files (issue 14): QGroundControl .plan read and written, KML field boundaries read.

The .plan and KML files in tests/support/mission_files are written by hand in the formats
QGroundControl and Google Earth save (QGroundControl's "Plan File Format": fileType "Plan",
version 1, mission.items with SimpleItems and a survey ComplexItem, geoFence, rallyPoints).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from dronefleet.geo.types import LLA
from dronefleet.ground.planner.files.imported import MissionFileError
from dronefleet.ground.planner.files.kml import read_kml
from dronefleet.ground.planner.files.plan import CIRCLE_SIDES, read_plan
from dronefleet.ground.planner.files.plan_export import write_plan

FILES = Path(__file__).parents[2] / "support" / "mission_files"


def plan_bytes(**mission) -> bytes:
    return json.dumps(
        {
            "fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
            "mission": {"version": 2, "plannedHomePosition": [40.63, -8.659, 10], **mission},
            "geoFence": {"version": 2, "polygons": [], "circles": []},
            "rallyPoints": {"version": 2, "points": []},
        }
    ).encode()  # fmt: skip


def simple(command: int, *params, frame: int = 3) -> dict:
    return {"type": "SimpleItem", "command": command, "frame": frame, "params": list(params),
            "autoContinue": True, "doJumpId": 1}  # fmt: skip


def test_a_qgroundcontrol_plan_reads_as_steps_fence_and_rally_points():
    got = read_plan((FILES / "field-waypoints.plan").read_bytes(), "field")
    steps = got.spec.steps
    assert steps is not None
    assert [s["command"] for s in steps] == [
        "arm", "takeoff", "wait_for_flight",
        "navigate", "wait_for_flight",
        "navigate", "wait_for_flight", "sleep", "takepic",
        "navigate", "wait_for_flight",
        "rtl", "wait_for_flight",
    ]  # fmt: skip
    assert steps[1]["value"] == 15
    assert steps[5] == {"command": "navigate", "lat": 40.631, "lon": -8.659, "altitude_delta": 20}
    assert steps[7]["value"] == 3  # the waypoint's hold time
    assert steps[9]["altitude_delta"] == pytest.approx(20)  # 30 m AMSL, home at 10 m
    fence = got.spec.options.geofence
    assert fence is not None and fence.inclusion is not None and len(fence.inclusion) == 4
    (circle,) = fence.exclusions
    assert len(circle) == CIRCLE_SIDES
    assert [(p.lat, p.lon, p.alt_m) for p in got.spec.options.rally_points] == [
        (40.6312, -8.6585, 15), (40.6299, -8.658, 12)
    ]  # fmt: skip
    assert got.home == [40.63, -8.659, 10]
    assert any("MAV_CMD_DO_CHANGE_SPEED left out" in w for w in got.warnings), got.warnings
    assert any("36-sided" in w for w in got.warnings)


def test_a_survey_alone_reads_as_the_planners_area():
    got = read_plan((FILES / "field-survey.plan").read_bytes())
    area = got.spec.area
    assert got.spec.steps is None and area is not None
    assert area.polygon[0] == (40.6302, -8.659) and len(area.polygon) == 4
    assert (area.spacing_m, area.altitude_m, area.angle_deg) == (12.5, 25, 0)
    assert area.action == "takepic" and area.fly_through and area.trigger_distance_m == 9.5


def test_a_survey_among_waypoints_is_flown_as_its_items():
    doc = json.loads((FILES / "field-survey.plan").read_text())
    doc["mission"]["items"].insert(1, simple(16, 0, 0, 0, None, 40.6301, -8.659, 20))
    got = read_plan(json.dumps(doc).encode())
    assert got.spec.area is None and got.spec.steps is not None
    navigates = [s for s in got.spec.steps if s["command"] == "navigate"]
    assert [(s["lat"], s["altitude_delta"]) for s in navigates] == [
        (40.6301, 20), (40.6302, 25), (40.6308, 25)
    ]  # fmt: skip
    triggers = [s["value"] for s in got.spec.steps if s["command"] == "camera_trigger"]
    assert triggers == [9.5, 0]


@pytest.mark.parametrize(
    ("data", "why"),
    [
        (b"{not json", r"not JSON"),
        (b'{"fileType": "Mission"}', r'no "fileType": "Plan"'),
        (b'{"fileType": "Plan", "version": 2}', r"version: Input should be 1"),
        (plan_bytes(items=[simple(16, 0, 0, 0)]), r"params: List should have at least 7"),
        (plan_bytes(items=[simple(17, 0, 0, 0, 0, 40.63, -8.659, 10)]),
         r"MAV_CMD_NAV_LOITER_UNLIM cannot be flown"),
        (plan_bytes(items=[simple(177, 1, 3, 0, 0, 0, 0, 0, frame=2)]),
         r"MAV_CMD_DO_JUMP cannot be flown"),
        (plan_bytes(items=[simple(16, 0, 0, 0, 0, 40.63, -8.659, 5, frame=0)]),
         r"-5.0 m is below home"),
        (plan_bytes(items=[simple(16, 0, 0, 0, 0, 40.63, -8.659, 5, frame=1)]),
         r"frame 1 is not a global frame"),
        (plan_bytes(items=[]), r"no item dronefleet can fly"),
        (plan_bytes(items=[simple(16, 0, 0, 0, 0, 95, -8.659, 5)]), r"not a \[lat, lon\]"),
    ],
)  # fmt: skip
def test_a_bad_plan_is_refused_with_the_reason(data: bytes, why: str):
    with pytest.raises(MissionFileError, match=why):
        read_plan(data)


def test_two_inclusion_zones_are_refused():
    doc = json.loads((FILES / "field-waypoints.plan").read_text())
    zone = doc["geoFence"]["polygons"][0]
    doc["geoFence"]["polygons"].append(zone)
    with pytest.raises(MissionFileError, match="2 inclusion zones; dronefleet keeps one"):
        read_plan(json.dumps(doc).encode())


def test_a_written_plan_reads_back_as_the_same_flight():
    steps = [
        {"command": "arm"}, {"command": "takeoff", "value": 12}, {"command": "wait_for_flight"},
        {"command": "navigate", "lat": 40.6303, "lon": -8.659, "altitude_delta": 15},
        {"command": "wait_for_flight"}, {"command": "takepic"},
        {"command": "changeN", "value": 20}, {"command": "wait_for_flight"},
        {"command": "sleep", "value": 4}, {"command": "camera_trigger", "value": 8},
        {"command": "sleep", "value": 2},
        {"command": "virtualalarm", "level": "CRITICAL"},
        {"command": "land"}, {"command": "wait_for_flight"},
    ]  # fmt: skip
    fence = {"inclusion": [[40.629, -8.66], [40.629, -8.657], [40.632, -8.657]],
             "exclusions": [[[40.6305, -8.6585], [40.6305, -8.6584], [40.6306, -8.6584]]],
             "ceiling_m": 60}  # fmt: skip
    rally = [{"lat": 40.6312, "lon": -8.6585, "alt_m": 15}]
    document = write_plan(steps, home=LLA(40.63, -8.659, 10), geofence=fence, rally_points=rally)
    assert document["fileType"] == "Plan" and document["version"] == 1
    assert [i["command"] for i in document["mission"]["items"]] == [22, 16, 203, 16, 206, 19, 21]
    back = read_plan(json.dumps(document).encode())
    assert back.spec.steps is not None
    navigates = [s for s in back.spec.steps if s["command"] == "navigate"]
    assert navigates[0] == steps[3]
    assert navigates[1]["lat"] == pytest.approx(40.6303 + 20 / 111_034, abs=2e-6)  # 20 m north
    assert navigates[1]["altitude_delta"] == 15
    sleeps = [s["value"] for s in back.spec.steps if s["command"] == "sleep"]
    assert sleeps == [4, 2]  # a waypoint's hold, then a loiter where it is
    options = back.spec.options
    assert options.geofence is not None and options.geofence.ceiling_m == 60
    assert options.geofence.inclusion == fence["inclusion"]
    assert options.geofence.exclusions == fence["exclusions"]
    assert [p.model_dump() for p in options.rally_points] == rally


def test_a_google_earth_polygon_reads_as_the_area_with_its_hole():
    got = read_kml((FILES / "field.kml").read_bytes())
    area = got.spec.area
    assert area is not None and got.spec.name == "North field"
    assert area.polygon == [(40.6302, -8.659), (40.6302, -8.658), (40.631, -8.658),
                            (40.631, -8.659)]  # fmt: skip
    assert len(area.holes) == 1 and area.holes[0][0] == (40.6305, -8.6586)
    assert area.spacing_m == 10 and area.altitude_m == 15


BILLION_LAUGHS = b"""<?xml version="1.0"?>
<!DOCTYPE kml [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">
<!ENTITY c "&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;"><!ENTITY d "&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;">]>
<kml><Placemark><name>&d;</name></Placemark></kml>"""
EXTERNAL = b"""<?xml version="1.0"?>
<!DOCTYPE kml [<!ENTITY secret SYSTEM "file:///etc/passwd">]>
<kml><Placemark><name>&secret;</name></Placemark></kml>"""


@pytest.mark.parametrize(
    ("data", "why"),
    [
        (BILLION_LAUGHS, r"refused, the file declares a DTD"),
        (EXTERNAL, r"refused, the file declares a DTD"),
        (b"PK\x03\x04rest-of-a-zip", r"KMZ"),
        (b"<kml><Document>", r"not well-formed XML"),
        (b"<gpx></gpx>", r"root element is <gpx>"),
        (b"<kml><Placemark><Point><coordinates>1,2</coordinates></Point></Placemark></kml>",
         r"no Polygon"),
        (b"<kml><Polygon><outerBoundaryIs><LinearRing><coordinates>1,2 x,y 3,4</coordinates>"
         b"</LinearRing></outerBoundaryIs></Polygon></kml>", r"coordinate 2 'x,y' is not lon,lat"),
        (b"<kml><Polygon><outerBoundaryIs><LinearRing><coordinates>1,2 3,4</coordinates>"
         b"</LinearRing></outerBoundaryIs></Polygon></kml>", r"at least 3 distinct vertices"),
    ],
)  # fmt: skip
def test_a_bad_kml_is_refused_with_the_reason(data: bytes, why: str):
    with pytest.raises(MissionFileError, match=why):
        read_kml(data)
