"""Three drones over MAVLink, one over UAVTalk and two in-process fly one collaborative mission
together (issue 6, Must show 4): the seed's collaborative-sensing area split among all six, every
waypoint reached, each backend's drones flying part of it — all in one simulated world.
"""

from __future__ import annotations

import pytest

from dronefleet.experiments.fleets import FcBackend
from dronefleet.experiments.harness import Harness
from dronefleet.experiments.scenarios import reached, rectangle
from dronefleet.geo.types import NED
from dronefleet.ground.planner import launch
from dronefleet.ground.planner.coverage import AreaSpec
from dronefleet.ground.planner.launch import MissionOptions, MissionSpec

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]

DRONES = [f"QUAD_{i}" for i in range(1, 7)]


async def test_mavlink_uavtalk_and_inprocess_drones_cover_one_area_together():
    async with Harness(speedup=10, fc=FcBackend.MIXED) as h:
        for i, drone_id in enumerate(DRONES):
            await h.add_drone(drone_id, NED(0, 12 * i))
        backends = dict(h.fleet.backends)
        assert sorted(backends.values()) == sorted(
            [FcBackend.MAVLINK] * 3 + [FcBackend.UAVTALK] + [FcBackend.SIM] * 2
        )
        await h.wait_identified(DRONES)
        await h.settle()
        area = AreaSpec(
            polygon=rectangle(10, 0, 28, 35),
            spacing_m=7,
            altitude_m=10,
            angle_deg=0,
            action="read_sensors",
            grid="seed",
        )
        spec = MissionSpec(
            name="mixed collaborative sensing",
            drones=DRONES,
            area=area,
            options=MissionOptions(replacement=False, collaboration=False),
        )
        record = await launch.create(h.planner, spec, start=True)
        record = await h.until_ended(record.mission_id, timeout_s=150)

    assert record.state.value == "completed", record.state
    planned, done = reached(record)
    assert planned > 20 and done == planned
    waypoints: dict[str, int] = {}
    readings: dict[str, int] = {}
    for leg in record.legs:
        for r in leg.reports:
            if r.index is None:
                continue
            command = record.work[r.index]["command"]
            if command == "wait_for_flight":
                waypoints[leg.drone_id] = waypoints.get(leg.drone_id, 0) + 1
            elif command == "read_sensors":
                readings[leg.drone_id] = readings.get(leg.drone_id, 0) + 1
    flew = {backends[d] for d, n in waypoints.items() if n > 0}
    assert flew == {FcBackend.MAVLINK, FcBackend.UAVTALK, FcBackend.SIM}, waypoints
    assert sum(waypoints.values()) >= planned
    assert {backends[d] for d in readings} == flew, readings
