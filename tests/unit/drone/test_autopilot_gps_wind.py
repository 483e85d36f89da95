"""GPS fix and wind as each autopilot backend reads them, for the heartbeat (issue 14)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from dronefleet.drone.fc.mavlink.state import VehicleView
from dronefleet.vehicle.base import GpsFix, GpsState, WindEstimate


def view(**latest) -> VehicleView:
    made = VehicleView()
    made.link = SimpleNamespace(latest=latest)  # type: ignore[assignment]
    return made


@pytest.mark.parametrize(
    ("fix_type", "fix"),
    [(0, GpsFix.NO_GPS), (1, GpsFix.NO_FIX), (2, GpsFix.FIX_2D), (3, GpsFix.FIX_3D),
     (6, GpsFix.FIX_3D)],
)  # fmt: skip
def test_mavlink_gps_raw_int_gives_the_fix_and_satellites(fix_type, fix):
    raw = SimpleNamespace(fix_type=fix_type, satellites_visible=9, eph=120)
    assert view(GPS_RAW_INT=raw).gps() == GpsState(fix, 9, 1.2)


def test_mavlink_without_gps_or_wind_says_so_and_never_guesses():
    assert view().gps() == GpsState(GpsFix.NO_GPS, 0)
    assert view().wind() is None  # the ground shows "unknown"
    unknown = SimpleNamespace(fix_type=3, satellites_visible=255, eph=0xFFFF)
    assert view(GPS_RAW_INT=unknown).gps() == GpsState(GpsFix.FIX_3D, 0, None)


def test_mavlink_wind_is_ardupilots_estimate():
    wind = SimpleNamespace(speed=4.5, direction=-90.0, speed_z=0.0)  # from the west
    assert view(WIND=wind).wind() == WindEstimate(4.5, 270.0)
