"""On-board missions with every end (issue 28, item 3).

Before, every share the planner made ended with ``rtl`` + ``wait_for_flight``, ``rtl`` had no
on-board form, and one such step sent the whole mission back to the companion computer without a
word: neither ``--onboard-missions`` nor ``options.onboard`` ever put the vehicle in AUTO. Now the
way home is NAV_RETURN_TO_LAUNCH, a landing NAV_LAND and a mission that stays up ends with
NAV_LOITER_UNLIM, flown by the simulated ArduPilot Copter behind our MAVLink endpoint (the
vehicles ``dronefleet sim --mavlink`` serves), with the planner's defaults.
"""

from __future__ import annotations

import asyncio
import math

import pytest

from dronefleet.experiments.fleets import FcBackend
from dronefleet.experiments.harness import ORIGIN, Harness
from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import NED
from dronefleet.ground.planner import launch
from dronefleet.ground.planner.models import MissionState
from dronefleet.ground.planner.options import MissionOptions
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.vehicle.base import FlightMode

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]


def steps() -> list[dict]:
    out = []
    for n, e in [(40, 0), (40, 30)]:
        p = ned_to_lla(NED(n, e), ORIGIN)
        out += [
            {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": 12},
            {"command": "wait_for_flight"},
        ]
    return out


async def fly(end_action: str, **options):
    """The planner's step mission with ``end_action`` on a MAVLink drone set to fly missions on
    board (``dronefleet drone --onboard-missions``); the record, the modes it flew in, the items
    the autopilot got and where the vehicle ended."""
    async with Harness(speedup=20, fc=FcBackend.MAVLINK) as h:
        await h.add_drone("QUAD_M", NED(0, 0), onboard_missions=True)
        await h.wait_identified(["QUAD_M"])
        await h.settle()
        fc = h.fleet.apps["QUAD_M"].fc
        modes: set[FlightMode] = set()

        async def watch() -> None:
            while True:
                state = fc.state()
                if state.in_air:
                    modes.add(state.mode)
                await h.clock.sleep(0.5)

        watcher = asyncio.create_task(watch())
        opts = MissionOptions(
            collaboration=False, replacement=False, end_action=end_action, **options
        )
        spec = launch.MissionSpec(name=end_action, drones=["QUAD_M"], steps=steps(), options=opts)
        record = await launch.create(h.planner, spec, start=True)
        record = await h.until_ended(record.mission_id, timeout_s=240)
        await h.settle(5.0)
        watcher.cancel()
        items = await fc.mission.download()
        state = fc.state()
        offset = lla_to_ned(fc.position(), fc.home())
    return record, modes, [i.command for i in items], state, offset


async def test_the_default_end_flies_home_on_board_in_auto_and_ends_disarmed_at_home():
    record, modes, items, state, offset = await fly("rtl")
    assert record.state is MissionState.COMPLETED, record.error
    assert modes == {FlightMode.MISSION}, modes  # AUTO all the way: never GUIDED, never RTL
    assert items[-1] == mav.MAV_CMD_NAV_RETURN_TO_LAUNCH, items
    assert not state.in_air and not state.armed
    assert math.hypot(offset.n, offset.e) < 3.0, offset
    (leg,) = record.legs
    assert [s["command"] for s in leg.suffix] == ["rtl", "wait_for_flight"]
    assert leg.flown_by is None  # the drone's configuration decides: it flew on board


async def test_a_mission_that_stays_up_holds_in_auto_where_its_work_ended():
    record, modes, items, state, offset = await fly("hold", onboard=True)
    assert record.state is MissionState.COMPLETED, record.error
    assert modes == {FlightMode.MISSION}, modes
    assert items[-1] == mav.MAV_CMD_NAV_LOITER_UNLIM, items
    assert state.in_air and state.mode is FlightMode.MISSION
    assert math.hypot(offset.n - 40, offset.e - 30) < 3.0, offset
    assert record.legs[0].flown_by == "autopilot"


async def test_a_mission_that_lands_lands_on_board():
    record, modes, items, state, offset = await fly("land")
    assert record.state is MissionState.COMPLETED, record.error
    assert modes == {FlightMode.MISSION}, modes
    assert items[-1] == mav.MAV_CMD_NAV_LAND, items
    assert not state.in_air and not state.armed
    assert math.hypot(offset.n - 40, offset.e - 30) < 3.0, offset
