"""An independent ground station flies ``dronefleet sim``: MAVSDK-Python (issue 10, must-show 1).

MAVSDK (its ``mavsdk_server`` binary from the wheel) drives a ``dronefleet sim`` process over
UDP as it would drive ArduPilot Copter: ``arm()`` immediately followed by ``takeoff()`` (failed
before: ARM was ACKed 3 s before the vehicle armed), goto, return to launch with the landing
disarmed by the vehicle itself, parameters read and written, a mission uploaded and downloaded
(home read back as item 0), a QGroundControl .plan imported and uploaded, and five vehicles, each
on its own port, a mission flown with ``start_mission`` and its progress followed to the end, and
offboard velocity control. Timeouts are wall seconds at 5x.
"""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest
from mavsdk import System
from mavsdk.mission_raw import MissionItem
from mavsdk.offboard import VelocityNedYaw

from dronefleet.messaging.embedded import free_port
from support.processes import dronefleet_sim

pytestmark = pytest.mark.integration

HOME = (40.63, -8.659, 10.0)
SPEEDUP = 5.0


def sim(count: int = 1):
    return dronefleet_sim(count, HOME, SPEEDUP)


async def connected(port: int) -> System:
    drone = System(port=free_port())  # its own mavsdk_server, on a free gRPC port
    await drone.connect(system_address=f"udpout://127.0.0.1:{port}")
    async with asyncio.timeout(30):
        async for state in drone.core.connection_state():
            if state.is_connected:
                break
        async for health in drone.telemetry.health():
            if health.is_armable and health.is_global_position_ok:
                break
    return drone


async def first(stream, predicate, timeout_s: float = 60.0):
    async with asyncio.timeout(timeout_s):
        async for value in stream:
            if predicate(value):
                return value


async def test_arm_then_takeoff_goto_and_home_landing_disarmed_by_itself():
    async with sim() as port:
        drone = await connected(port)
        await drone.action.set_takeoff_altitude(10.0)
        await drone.action.arm()
        await drone.action.takeoff()  # at once: ArduPilot has armed by the time it ACKs
        await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 9.0)
        north = HOME[0] + 30 / 111_320
        await drone.action.goto_location(north, HOME[1], HOME[2] + 10, 0)
        await first(drone.telemetry.position(), lambda p: abs(p.latitude_deg - north) < 2e-5)
        await drone.action.return_to_launch()
        await first(drone.telemetry.armed(), lambda armed: not armed, 120)
        here = await first(drone.telemetry.position(), lambda p: True)
        assert abs(here.latitude_deg - HOME[0]) < 3e-5 and here.relative_altitude_m < 0.5


async def up(drone: System) -> None:
    await drone.action.set_takeoff_altitude(10.0)
    await drone.action.arm()
    await drone.action.takeoff()
    await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 9.0)


async def test_a_mission_is_started_followed_to_its_end_and_lands_at_home():
    # ArduPilot Copter armed in AUTO on the ground waits for throttle or MISSION_START (MAVSDK
    # sends neither), so its users take off in GUIDED and then start the mission in the air.
    wps = [(HOME[0] + n / 111_320, HOME[1]) for n in (20, 40)]
    items = [item(0, 16, HOME[0], HOME[1], 0), item(1, 22),
             *(item(i + 2, 16, *wp) for i, wp in enumerate(wps)), item(4, 20)]  # fmt: skip
    async with sim() as port:
        drone = await connected(port)
        await drone.mission_raw.upload_mission(items)
        await up(drone)
        seen: list[int] = []

        async def progress() -> None:
            async for p in drone.mission_raw.mission_progress():
                seen.append(p.current)
                if p.current == p.total == len(items):
                    return

        await drone.mission_raw.start_mission()
        async with asyncio.timeout(90):
            await progress()
        assert seen == sorted(seen) and {2, 3, 4} <= set(seen), seen
        await first(drone.telemetry.armed(), lambda armed: not armed, 120)  # the RTL item lands
        here = await first(drone.telemetry.position(), lambda p: True)
        assert abs(here.latitude_deg - HOME[0]) < 3e-5 and here.relative_altitude_m < 0.5


async def test_offboard_velocity_moves_the_vehicle_and_stops_with_it():
    async with sim() as port:
        drone = await connected(port)
        await up(drone)
        await drone.offboard.set_velocity_ned(VelocityNedYaw(2.0, 0.0, 0.0, 0.0))
        await drone.offboard.start()
        moving = await first(
            drone.telemetry.position_velocity_ned(), lambda p: p.position.north_m > 20, 60
        )
        assert moving.velocity.north_m_s == pytest.approx(2.0, abs=0.3)
        assert abs(moving.position.east_m) < 1.0 and moving.position.down_m == pytest.approx(
            -10.0, abs=1.0
        )
        await drone.offboard.set_velocity_ned(VelocityNedYaw(0.0, 0.0, 0.0, 0.0))
        await first(
            drone.telemetry.position_velocity_ned(), lambda p: abs(p.velocity.north_m_s) < 0.1, 30
        )
        await drone.offboard.stop()


async def test_parameters_are_read_and_written():
    async with sim() as port:
        drone = await connected(port)
        speed = await drone.param.get_param_float("WPNAV_SPEED")
        assert speed == pytest.approx(1000.0)  # cm/s, ArduPilot Copter's default
        await drone.param.set_param_float("WPNAV_SPEED", 700.0)
        assert await drone.param.get_param_float("WPNAV_SPEED") == pytest.approx(700.0)
        assert (await drone.param.get_param_int("DISARM_DELAY")) == 10


def item(seq: int, command: int, lat: float = 0, lon: float = 0, alt: float = 10) -> MissionItem:
    return MissionItem(seq, 3, command, 1 if seq == 0 else 0, 1, 0, 0, 0, 0,
                       int(lat * 1e7), int(lon * 1e7), alt, 0)  # fmt: skip


async def test_a_mission_is_uploaded_and_downloaded_as_sent():
    # On ArduPilot item 0 is home, as MAVSDK's users of ArduPilot send it.
    wps = [(HOME[0] + n / 111_320, HOME[1]) for n in (20, 40)]
    items = [item(0, 16, HOME[0], HOME[1], 0), item(1, 22),
             *(item(i + 2, 16, *wp) for i, wp in enumerate(wps)), item(4, 21)]  # fmt: skip
    async with sim() as port:
        drone = await connected(port)
        await drone.mission_raw.upload_mission(items)
        got = await drone.mission_raw.download_mission()
    assert [(i.command, i.x, i.y) for i in got[1:]] == [(i.command, i.x, i.y) for i in items[1:]]
    assert (got[0].x, got[0].y) == (items[0].x, items[0].y)  # home, read back as item 0


async def test_a_qgroundcontrol_plan_imports_and_uploads(tmp_path: Path):
    plan = {
        "fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
        "geoFence": {"circles": [], "polygons": [], "version": 2},
        "rallyPoints": {"points": [], "version": 2},
        "mission": {
            "version": 2, "firmwareType": 3, "vehicleType": 2, "cruiseSpeed": 10,
            "hoverSpeed": 5, "plannedHomePosition": list(HOME),
            "items": [
                {"type": "SimpleItem", "autoContinue": True, "command": 22, "doJumpId": 1,
                 "frame": 3, "params": [0, 0, 0, None, 0, 0, 10]},
                {"type": "SimpleItem", "autoContinue": True, "command": 16, "doJumpId": 2,
                 "frame": 3, "params": [0, 0, 0, None, HOME[0] + 0.0002, HOME[1], 10]},
                {"type": "SimpleItem", "autoContinue": True, "command": 20, "doJumpId": 3,
                 "frame": 2, "params": [0, 0, 0, 0, 0, 0, 0]},
            ],
        },
    }  # fmt: skip
    path = tmp_path / "survey.plan"
    path.write_text(json.dumps(plan))
    async with sim() as port:
        drone = await connected(port)
        imported = await drone.mission_raw.import_qgroundcontrol_mission(str(path))
        # For ArduPilot (firmwareType 3) MAVSDK puts the planned home first, as item 0.
        assert [i.command for i in imported.mission_items] == [16, 22, 16, 20]
        await drone.mission_raw.upload_mission(imported.mission_items)
        got = await drone.mission_raw.download_mission()
    assert [i.command for i in got] == [16, 22, 16, 20]
    assert got[2].x == int((HOME[0] + 0.0002) * 1e7)


async def test_five_vehicles_each_answer_on_its_own_port_from_its_own_place():
    async with sim(count=5) as port:
        places = set()
        for i in range(5):
            drone = await connected(port + i)
            here = await first(drone.telemetry.position(), lambda p: True)
            places.add((round(here.latitude_deg, 6), round(here.longitude_deg, 6)))
        assert len(places) == 5, places  # five vehicles, not one answering five times
