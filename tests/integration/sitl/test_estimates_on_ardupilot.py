"""The preview's time is the flown time on ArduPilot, the way home included (issue 28, item 8).

Before: the default end (``rtl``) was estimated at 0 s, so the planner's default step mission
previewed 70 s and flew 127 s; and the SITL tests never saw it, each ending its missions with a
``land`` of its own, near the same field, in calm air, at ArduPilot's default speed. Here the
planner's defaults fly far from that field (Sydney), in a steady wind (SIM_WIND_SPD,
SIM_WIND_DIR: blowing from the east, against the first leg), at a WP_SPD that is not the
default, and the preview must be within 10 % of the flight (it was 110.4 s, 52.6 s of it the
way home, for 107.2 s flown).
"""

from __future__ import annotations

import pytest

from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED

pytestmark = [pytest.mark.integration, pytest.mark.sitl]

SYDNEY = (-33.9, 151.2, 30.0)
WIND_MPS = 6.0
WIND_FROM_DEG = 90.0  # SIM_WIND_DIR: where it blows from
PARAMS = {
    "SIM_WIND_SPD": WIND_MPS,
    "SIM_WIND_DIR": WIND_FROM_DEG,
    "SIM_WIND_TURB": 0,
    "WP_SPD": 8.0,  # m/s (WPNAV_SPEED 800 cm/s before ArduPilot 4.7's SI names)
}


def test_the_preview_with_its_way_home_is_the_flight_far_away_in_the_wind(ground, fly):
    fly("SITL_W", params=PARAMS, home=SYDNEY)
    drone = ground.drone("SITL_W")
    h = drone["home"]
    home = LLA(h["lat"], h["lon"], h["alt_m"])
    assert abs(home.lat - SYDNEY[0]) < 1e-3 and abs(home.lon - SYDNEY[1]) < 1e-3
    assert drone["flight"]["speed_mps"] == pytest.approx(8.0)
    steps = []
    for n, e in [(0, 120), (80, 120), (80, 0)]:  # east into the wind, north, west with it
        p = ned_to_lla(NED(n, e, 0), home)
        steps += [
            {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": 20},
            {"command": "wait_for_flight"},
        ]
    spec = {
        "name": "far, windy",
        "drones": ["SITL_W"],
        "steps": steps,  # the planner's defaults: climb while flying, home by RTL
        "options": {"wind_mps": WIND_MPS, "wind_from_deg": WIND_FROM_DEG},
    }
    preview = ground.api("POST", "/api/v1/missions/preview", json=spec)
    assert preview.status_code == 200, preview.text
    (share,) = preview.json()["drones"]
    assert share["end"] == ["rtl", "wait_for_flight"]
    assert share["return_s"] > 40  # 80 m home, 5 s over it, 20 m down (the last 10 at 0.5 m/s)
    assert any("wind 6 m/s from 90°" in note for note in share["notes"]), share["notes"]
    mission = ground.run_mission(spec)
    assert mission["state"] == "completed", mission.get("error")
    record = ground.api("GET", f"/api/v1/missions/{mission['mission_id']}").json()
    (leg,) = record["legs"]
    flown_s = leg["ended_vehicle_s"] - leg["started_vehicle_s"]
    assert share["duration_s"] == pytest.approx(flown_s, rel=0.10), (share, flown_s)
    drone = ground.drone("SITL_W")
    assert drone["state"] == "disarmed"
    here = drone["position"]
    assert lla_to_ned(LLA(here["lat"], here["lon"], home.alt_m), home).horizontal_m < 5.0
