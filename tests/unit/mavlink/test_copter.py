"""The simulated ArduPilot Copter without a network: its modes refuse what Copter refuses, and
AUTO flies an uploaded mission on board, item by item."""

from __future__ import annotations

import pytest

from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.protocols.mavlink import items as mi
from dronefleet.protocols.mavlink.modes import CopterMode
from dronefleet.sim.camera import SimCamera
from dronefleet.sim.mavlink.copter import CommandRefused, CopterEvents, SimCopter
from dronefleet.sim.vehicle import SimVehicle

HOME = LLA(40.63, -8.659, 10.0)


class Recorder(CopterEvents):
    def __init__(self) -> None:
        self.texts: list[str] = []
        self.reached: list[int] = []
        self.current: list[int] = []
        self.pictures: list[dict] = []

    def statustext(self, severity, text):
        self.texts.append(text)

    def mission_current(self, seq):
        self.current.append(seq)

    def item_reached(self, seq):
        self.reached.append(seq)

    def captured(self, info):
        self.pictures.append(info)


def make(**params) -> tuple[SimCopter, Recorder]:
    vehicle = SimVehicle("Q", HOME, **params)
    events = Recorder()
    return SimCopter(vehicle, camera=SimCamera(vehicle), events=events), events


def run(copter: SimCopter, seconds: float, step: float = 0.05) -> None:
    for _ in range(round(seconds / step)):
        copter.vehicle.step(step)
        copter.update()


def test_takeoff_only_in_guided_and_armed():
    copter, _ = make(arming_s=0)
    copter.arm()
    with pytest.raises(CommandRefused, match="not in GUIDED"):
        copter.takeoff(10)
    copter.set_mode(CopterMode.GUIDED)
    copter.takeoff(10)
    run(copter, 8)
    assert copter.vehicle.relative_alt_m == pytest.approx(10, abs=0.05)
    with pytest.raises(CommandRefused, match="already flying"):
        copter.takeoff(20)


def test_no_arming_in_auto_or_land_and_low_battery_says_why():
    copter, _ = make()
    copter.set_mode(CopterMode.LAND)
    with pytest.raises(CommandRefused, match="Mode not armable"):
        copter.arm()
    low, _ = make(initial_charge_pct=2)
    with pytest.raises(CommandRefused, match=r"^Arm: battery at 2\.0 %"):
        low.arm()


def test_rtl_climbs_flies_home_and_lands():
    copter, _ = make(arming_s=0)
    copter.set_mode(CopterMode.GUIDED)
    copter.arm()
    copter.takeoff(5)
    run(copter, 5)
    copter.guided_target(NED(30, 0, -5))
    run(copter, 8)
    copter.set_mode(CopterMode.RTL)
    run(copter, 7)
    assert copter.vehicle.relative_alt_m == pytest.approx(15, abs=0.5)  # RTL_ALT first
    run(copter, 40)
    assert not copter.vehicle.in_air and not copter.vehicle.armed
    assert copter.vehicle.position_ned.horizontal_m < 0.5


def test_auto_flies_the_mission_and_reports_each_item():
    copter, events = make(arming_s=0)
    wp = ned_to_lla(NED(30, 0), HOME)
    home_item = mi.MissionItem(mi.mav.MAV_CMD_NAV_WAYPOINT, z=HOME.alt_m, frame=mi.ABSOLUTE)
    copter.on_mission_replaced(
        [
            home_item,
            mi.takeoff(8),
            mi.waypoint(wp.lat, wp.lon, 8, hold_s=2),
            mi.take_photo(),
            mi.land(),
        ]
    )
    copter.set_mode(CopterMode.GUIDED)
    copter.arm()
    copter.start_mission()  # MISSION_START: AUTO on the ground waits for it
    run(copter, 60)
    assert events.reached == [1, 2, 4]
    assert events.current[:3] == [1, 2, 4]
    assert len(events.pictures) == 1  # DO_DIGICAM runs once the waypoint (and its hold) is done
    assert not copter.vehicle.in_air
    assert lla_to_ned(copter.vehicle.position_lla, HOME).n == pytest.approx(30, abs=0.5)
    assert copter.runner.finished


def test_auto_needs_a_mission():
    copter, _ = make()
    with pytest.raises(CommandRefused, match="no mission"):
        copter.set_mode(CopterMode.AUTO)
