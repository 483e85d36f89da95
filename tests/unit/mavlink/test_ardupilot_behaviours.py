"""The simulated Copter does what ArduPilot Copter does where a forgiving simulator would not
(issue 17; ArduPilot upstream 64a9c78, the commit our SITL is built from). Each of these passed
on the simulator before this change only by being wrong: the old simulator lifted off on a
position target sent while landed, never disarmed on its own, started AUTO missions on the
ground by itself, took first/last items in MISSION_START, and answered a camera command it
could not serve with UNSUPPORTED where SITL says FAILED.
"""

from __future__ import annotations

import pytest

from dronefleet.geo.types import LLA, NED
from dronefleet.protocols.mavlink import items as mi
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.modes import CopterMode
from dronefleet.sim.camera import SimCamera
from dronefleet.sim.mavlink.copter import CopterEvents, SimCopter
from dronefleet.sim.mavlink.handlers import CommandHandler
from dronefleet.sim.vehicle import SimVehicle

HOME = LLA(40.63, -8.659, 10.0)


def make(camera: bool = False) -> SimCopter:
    vehicle = SimVehicle("Q", HOME, arming_s=0)
    return SimCopter(vehicle, camera=SimCamera(vehicle) if camera else None, events=CopterEvents())


def run(copter: SimCopter, seconds: float, step: float = 0.05) -> None:
    for _ in range(round(seconds / step)):
        copter.vehicle.step(step)
        copter.update()


class _Endpoint:  # what CommandHandler needs of an endpoint for these commands
    def __init__(self, copter: SimCopter) -> None:
        self.copter = copter


def command(copter: SimCopter, cmd: int, *params: float) -> int:
    handlers = CommandHandler(_Endpoint(copter))  # type: ignore[arg-type]
    p = [*params, 0, 0, 0, 0, 0, 0, 0][:7]
    result, _ = handlers.command(mav.MAVLink_command_long_message(1, 1, cmd, 0, *p))
    return result


def test_a_position_target_right_after_takeoff_leaves_the_copter_on_the_ground():
    # ModeGuided::set_destination (ArduCopter/mode_guided.cpp) turns the take-off into a waypoint,
    # and the waypoint controller keeps the motors idle while landed.
    copter = make()
    copter.set_mode(CopterMode.GUIDED)
    copter.arm()
    copter.takeoff(10)
    run(copter, 0.05)
    copter.guided_target(NED(100, 0, -10))
    run(copter, 5)
    assert not copter.vehicle.in_air and copter.vehicle.relative_alt_m == pytest.approx(0)
    assert copter.vehicle.armed  # idle on the ground, until DISARM_DELAY


def test_a_position_target_once_airborne_is_flown():
    copter = make()
    copter.set_mode(CopterMode.GUIDED)
    copter.arm()
    copter.takeoff(10)
    run(copter, 3)
    assert copter.vehicle.relative_alt_m > 2
    copter.guided_target(NED(50, 0, -10))
    run(copter, 20)
    assert copter.vehicle.position_ned.n == pytest.approx(50, abs=1)


def test_armed_and_idle_on_the_ground_it_disarms_after_disarm_delay():
    # Copter::auto_disarm_check (ArduCopter/motors.cpp), DISARM_DELAY 10 s by default.
    copter = make()
    copter.set_mode(CopterMode.GUIDED)
    copter.arm()
    run(copter, 9.5)
    assert copter.vehicle.armed
    run(copter, 1.0)
    assert not copter.vehicle.armed


def test_auto_on_the_ground_waits_for_mission_start():
    copter = make()
    copter.on_mission_replaced([mi.MissionItem(mi.mav.MAV_CMD_NAV_WAYPOINT), mi.takeoff(8)])
    copter.set_mode(CopterMode.GUIDED)
    copter.arm()
    copter.set_mode(CopterMode.AUTO)
    run(copter, 3)
    assert not copter.vehicle.in_air
    assert command(copter, mav.MAV_CMD_MISSION_START, 0, 0) == mav.MAV_RESULT_ACCEPTED
    run(copter, 3)
    assert copter.vehicle.relative_alt_m > 2


def test_mission_start_with_a_first_or_last_item_is_denied():
    # GCS_MAVLink_Copter.cpp, MAV_CMD_MISSION_START: "first-item/last item not supported".
    copter = make()
    copter.on_mission_replaced([mi.MissionItem(mi.mav.MAV_CMD_NAV_WAYPOINT), mi.takeoff(8)])
    copter.set_mode(CopterMode.GUIDED)
    copter.arm()
    assert command(copter, mav.MAV_CMD_MISSION_START, 1, 0) == mav.MAV_RESULT_DENIED
    assert command(copter, mav.MAV_CMD_MISSION_START, 0, 1) == mav.MAV_RESULT_DENIED
    assert copter.mode is CopterMode.GUIDED


def test_a_camera_command_without_a_camera_fails_and_with_one_is_taken():
    # SITL with CAM1_TYPE 0 answers IMAGE_START_CAPTURE with MAV_RESULT_FAILED.
    assert command(make(), mav.MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1, 1) == mav.MAV_RESULT_FAILED
    copter = make(camera=True)
    assert command(copter, mav.MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1, 1) == mav.MAV_RESULT_ACCEPTED
    assert copter.picture_count == 1


def test_landing_from_10_m_takes_ardupilots_time_and_ends_disarmed():
    # Down to LAND_ALT_LOW (10 m) at WPNAV_SPEED_DN, then LAND_SPEED 0.5 m/s: ~20 s from 10 m.
    copter = make()
    copter.set_mode(CopterMode.GUIDED)
    copter.arm()
    copter.takeoff(10)
    run(copter, 10)
    assert copter.vehicle.relative_alt_m == pytest.approx(10, abs=0.3)
    copter.set_mode(CopterMode.LAND)
    seconds = 0.0
    while copter.vehicle.in_air and seconds < 60:
        run(copter, 0.05)
        seconds += 0.05
    assert 15 <= seconds <= 25
    run(copter, 1.1)  # the land detector's second on the ground, then ModeLand disarms
    assert not copter.vehicle.armed


def _mission(copter: SimCopter, *items: mi.MissionItem) -> None:
    home = mi.MissionItem(mav.MAV_CMD_NAV_WAYPOINT, z=HOME.alt_m, frame=mi.ABSOLUTE)
    copter.on_mission_replaced([home, *items])
    copter.set_mode(CopterMode.GUIDED)
    copter.arm()
    copter.start_mission()


def _north_m(info: dict) -> float:
    from dronefleet.geo.ned import lla_to_ned

    return lla_to_ned(LLA(info["lat"], info["lon"], HOME.alt_m), HOME).n


def test_a_do_command_after_a_waypoint_runs_when_the_waypoint_is_reached():
    # AP_Mission::advance_current_nav_cmd starts the DO commands it passes on its way from the
    # completed NAV command to the next one: a photo after a waypoint is taken there, not as the
    # vehicle sets off towards it (which is what this simulator did).
    from dronefleet.geo.ned import ned_to_lla

    copter = make(camera=True)
    pictures: list[dict] = []
    copter.events.captured = pictures.append  # type: ignore[method-assign]
    a, b = ned_to_lla(NED(40, 0), HOME), ned_to_lla(NED(80, 0), HOME)
    _mission(
        copter,
        mi.takeoff(10),
        mi.waypoint(a.lat, a.lon, 10),
        mi.take_photo(),
        mi.waypoint(b.lat, b.lon, 10),
        mi.land(),
    )
    run(copter, 90)
    assert len(pictures) == 1
    assert _north_m(pictures[0]) == pytest.approx(40, abs=2.5)  # inside WPNAV_RADIUS (2 m)


def test_the_distance_trigger_photographs_every_n_metres_until_set_to_zero():
    # AP_Mission::start_command_camera: DO_SET_CAM_TRIGG_DIST sets the distance (param1) and,
    # with param3 = 1, takes one picture at once; zero stops it.
    from dronefleet.geo.ned import ned_to_lla

    copter = make(camera=True)
    pictures: list[dict] = []
    copter.events.captured = pictures.append  # type: ignore[method-assign]
    a, b, c = (ned_to_lla(NED(n, 0), HOME) for n in (20, 85, 120))
    trigger = mi.MissionItem(
        mav.MAV_CMD_DO_SET_CAM_TRIGG_DIST, param1=15, param3=1, frame=mav.MAV_FRAME_MISSION
    )
    stop = mi.MissionItem(mav.MAV_CMD_DO_SET_CAM_TRIGG_DIST, frame=mav.MAV_FRAME_MISSION)
    _mission(
        copter,
        mi.takeoff(10),
        mi.waypoint(a.lat, a.lon, 10),
        trigger,
        mi.waypoint(b.lat, b.lon, 10),
        stop,
        mi.waypoint(c.lat, c.lon, 10),
        mi.land(),
    )
    run(copter, 120)
    norths = [_north_m(p) for p in pictures]
    # From where 20 m was reached (inside WPNAV_RADIUS, 2 m) every 15 m; none after 85 m.
    assert len(norths) == 5, norths
    assert norths == pytest.approx([18 + 15 * k for k in range(5)], abs=1.0)
    assert command(copter, mav.MAV_CMD_DO_SET_CAM_TRIGG_DIST, 10) == mav.MAV_RESULT_ACCEPTED
    assert command(make(), mav.MAV_CMD_DO_SET_CAM_TRIGG_DIST, 10) == mav.MAV_RESULT_FAILED
