"""The .plan files dronefleet writes are read by MAVSDK-Python (issue 14): its
``mission_raw.import_qgroundcontrol_mission`` (parsed by ``mavsdk_server``, the importer
QGroundControl users' scripts rely on) gives the mission items, the geofence and the rally
points, and the mission uploads to and downloads from ``dronefleet sim`` as written.

The files are made as the export route makes them (ground/planner/files/plan_export.py): from a
hand-written QGroundControl .plan read by the import, and from a Google Earth field planned into
a survey.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from dronefleet.geo.types import LLA
from dronefleet.ground.planner.coverage import plan_area
from dronefleet.ground.planner.files.kml import read_kml
from dronefleet.ground.planner.files.plan import read_plan
from dronefleet.ground.planner.files.plan_export import write_plan
from dronefleet.protocols.mavlink.codec import dialect as mav

from .test_mavsdk import HOME, connected, sim

pytestmark = pytest.mark.integration
FILES = Path(__file__).parents[3] / "support" / "mission_files"


def exported(tmp_path: Path, name: str, steps, spec_options) -> Path:
    document = write_plan(
        steps, home=LLA(*HOME),
        geofence=spec_options.geofence.model_dump() if spec_options.geofence else None,
        rally_points=[p.model_dump() for p in spec_options.rally_points],
    )  # fmt: skip
    path = tmp_path / name
    path.write_text(json.dumps(document))
    return path


async def test_mavsdk_imports_an_exported_plan_with_its_fence_and_rally_points(tmp_path):
    spec = read_plan((FILES / "field-waypoints.plan").read_bytes()).spec
    assert spec.steps is not None
    path = exported(tmp_path, "field.plan", spec.steps, spec.options)
    async with sim() as port:
        drone = await connected(port)
        got = await drone.mission_raw.import_qgroundcontrol_mission(str(path))
        items = got.mission_items
        # ArduPilot (firmwareType 3): MAVSDK puts the planned home first, as item 0.
        assert [i.command for i in items] == [16, 22, 16, 16, 203, 16, 20]
        assert (items[0].x, items[0].y) == (int(HOME[0] * 1e7), int(HOME[1] * 1e7))
        assert (items[3].x, items[3].y, items[3].z, items[3].param1) == (406310000, -86590000,
                                                                          20, 3)  # fmt: skip
        assert all(i.frame == mav.MAV_FRAME_GLOBAL_RELATIVE_ALT for i in items[1:4])
        # The fence: 4 inclusion vertices (each says its polygon's size), a 36-gon exclusion.
        fence = [(i.command, i.param1) for i in got.geofence_items]
        assert fence[:4] == [(mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, 4)] * 4
        assert fence[4:] == [(mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION, 36)] * 36
        rally = [(i.command, i.x, i.y, i.z) for i in got.rally_items]
        assert rally == [
            (mav.MAV_CMD_NAV_RALLY_POINT, 406312000, -86585000, 15),
            (mav.MAV_CMD_NAV_RALLY_POINT, 406299000, -86580000, 12),
        ]
        await drone.mission_raw.upload_mission(items)
        down = await drone.mission_raw.download_mission()
    assert [(i.command, i.x, i.y) for i in down[1:]] == [(i.command, i.x, i.y) for i in items[1:]]


async def test_mavsdk_imports_a_google_earth_field_planned_and_exported(tmp_path):
    spec = read_kml((FILES / "field.kml").read_bytes()).spec
    assert spec.area is not None
    plan = plan_area(spec.area)
    path = exported(tmp_path, "survey.plan", plan.mission_steps(), spec.options)
    async with sim() as port:
        drone = await connected(port)
        got = await drone.mission_raw.import_qgroundcontrol_mission(str(path))
    waypoints = [(i.x, i.y) for i in got.mission_items if i.command == 16][1:]  # after home
    assert waypoints == [(round(p.lat * 1e7), round(p.lon * 1e7)) for p in plan.waypoints]
    assert not got.geofence_items and not got.rally_items
