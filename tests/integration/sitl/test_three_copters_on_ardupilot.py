"""Three ArduPilot copters at once (issue 28, item 8): collaboration from ``--plume``, the grown
area split among the three, and their returns to homes 6 m apart, with the planner's defaults.

Before: collaboration on SITL needed an outside script sending NAMED_VALUE_FLOAT "CO2"; and three
vehicles with homes 6 m apart, finishing together, were flown home by ArduPilot's RTL at the same
20 m: two came within 3.92 m horizontally and 0.5 m vertically. Here the first copter carries a
simulated CO2 sensor (``dronefleet drone --plume``) and surveys an area over the plume alone; its
OUT_MEASURE alarm must grow the area and split it among the three, every waypoint must be reached
once, every copter must land at its own home, and the ground's separation monitor (5 m
horizontally and 3 m vertically) must have seen no two of them closer.
"""

from __future__ import annotations

import time

import pytest

from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from support.sitl import HOME

pytestmark = [pytest.mark.integration, pytest.mark.sitl]

DRONES = ("SITL_1", "SITL_2", "SITL_3")
ORIGIN = LLA(*HOME)


def _home_of(i: int) -> tuple[float, float, float]:
    p = ned_to_lla(NED(0, 6 * i, 0), ORIGIN)  # homes 6 m apart, west to east
    return (p.lat, p.lon, HOME[2])


def test_a_plume_grows_the_area_for_three_copters_and_they_come_home_apart(ground, fly):
    plume = ned_to_lla(NED(60, 20, 0), ORIGIN)  # inside the area, 3000 ppm at its centre
    fly("SITL_1", "--plume", f"{plume.lat},{plume.lon},3000,15", home=_home_of(0))
    fly("SITL_2", home=_home_of(1))
    fly("SITL_3", home=_home_of(2))
    corners = [ned_to_lla(NED(n, e, 0), ORIGIN) for n, e in [(40, 0), (80, 0), (80, 40), (40, 40)]]
    spec = {
        "name": "plume",
        "drones": ["SITL_1"],
        "area": {
            "polygon": [[c.lat, c.lon] for c in corners],
            "spacing_m": 20,
            "altitude_m": 20,
            "action": "read_sensors",
            "hold_s": 1,
        },
    }
    mission = ground.run_mission(spec, timeout_s=400)
    assert mission["state"] == "completed", mission.get("error")
    record = ground.api("GET", f"/api/v1/missions/{mission['mission_id']}").json()
    (expansion,) = record["expansions"]
    assert set(expansion["assignments"]) == set(DRONES), expansion["assignments"]
    work = record["work"]
    reached = [
        r["index"]
        for leg in record["legs"]
        for r in leg["reports"]
        if r["index"] is not None and work[r["index"]]["command"] == "wait_for_flight"
    ]
    assert sorted(reached) == sorted(set(reached)), "a waypoint was reached twice"
    assert mission["waypoints_reached"] == mission["waypoints"]
    deadline = time.monotonic() + 60
    for i, drone_id in enumerate(DRONES):  # each down at its own home
        while (drone := ground.drone(drone_id))["state"] != "disarmed":
            assert time.monotonic() < deadline, f"{drone_id} still {drone['state']}"
            time.sleep(0.5)
        here = LLA(drone["position"]["lat"], drone["position"]["lon"], HOME[2])
        assert lla_to_ned(here, LLA(*_home_of(i))).horizontal_m < 3.0, (drone_id, here)
    separation = ground.api("GET", "/api/v1/separation").json()
    assert separation["actual_breaches"] == 0, separation
    print(  # the figures, for the notes (pytest -s)
        f"expansion to {expansion['area_m2']:.0f} m2 over {sorted(expansion['assignments'])};"
        f" {len(reached)} waypoints; closest {separation['min_horizontal_m']} m horizontally"
    )
