"""Issue 10, items 1-3: armed when the arm command is ACKed, healthy as ArduPilot says so, and
MAVFTP refused at once.

MAVSDK's ``arm()`` then ``takeoff()`` (and MAVProxy's ``arm throttle`` then ``takeoff 10``)
failed with "not armed": the ACK came at once but the vehicle armed 3 s later.
"""

from __future__ import annotations

from dronefleet.geo.types import LLA
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.modes import CopterMode
from dronefleet.sim.mavlink import ftp, streams
from dronefleet.sim.mavlink.copter import CopterEvents, SimCopter
from dronefleet.sim.mavlink.server import MavlinkSimServer
from dronefleet.sim.vehicle import SimVehicle
from dronefleet.sim.world import SimWorld
from unit.mavlink.test_ardupilot_behaviours import make

HOME = LLA(40.63, -8.659, 10.0)


def command(endpoint, cmd: int, *params: float) -> int:
    values = [*params, *[0.0] * (7 - len(params))]
    msg = mav.MAVLink_command_long_message(1, 1, cmd, 0, *values)
    result, _ = endpoint.commands.command(msg)
    return result


def test_the_ack_of_arm_comes_with_the_vehicle_armed_and_takeoff_follows_at_once():
    server = MavlinkSimServer(SimWorld(), base_port=0)
    endpoint = server.add_vehicle(HOME, port=0)
    endpoint.copter.set_mode(CopterMode.GUIDED)
    assert command(endpoint, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    assert endpoint.copter.vehicle.armed  # no vehicle time has passed
    takeoff = command(endpoint, mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10)
    assert takeoff == mav.MAV_RESULT_ACCEPTED


def test_sys_status_says_armable_and_no_fence_breach_as_ardupilot_does():
    """Item 2: MAVSDK's health.is_armable reads the pre-arm bit; MAVProxy took the missing
    geofence health bit for a breach at every connect."""
    copter = make()
    status = streams.sys_status(copter, None)
    for bit in (mav.MAV_SYS_STATUS_PREARM_CHECK, mav.MAV_SYS_STATUS_GEOFENCE):
        assert status.onboard_control_sensors_present & bit
        assert status.onboard_control_sensors_health & bit
    assert (
        not status.onboard_control_sensors_enabled & mav.MAV_SYS_STATUS_GEOFENCE
    )  # FENCE_ENABLE 0
    copter.params.set("FENCE_ENABLE", 1)
    assert streams.sys_status(copter, None).onboard_control_sensors_enabled & (
        mav.MAV_SYS_STATUS_GEOFENCE
    )
    flat = SimCopter(SimVehicle("F", HOME, initial_charge_pct=3.0), events=CopterEvents())
    unhealthy = streams.sys_status(flat, None).onboard_control_sensors_health
    assert not unhealthy & mav.MAV_SYS_STATUS_PREARM_CHECK  # a flat battery fails the pre-arm


def _ftp(opcode: int, seq: int = 7) -> mav.MAVLink_file_transfer_protocol_message:
    path = b"@PARAM/param.pck"
    payload = bytes([seq, 0, 0, opcode, len(path), 0, 0, 0, 0, 0, 0, 0]) + path
    msg = mav.MAVLink_file_transfer_protocol_message(0, 1, 1, list(payload.ljust(251, b"\0")))
    msg._header = mav.MAVLink_header(0, 0, 0, srcSystem=255, srcComponent=190)
    return msg


def test_mavftp_is_refused_at_once_so_ground_stations_fall_back_to_the_parameter_list():
    """Item 3: MAVProxy waited 11 s for an answer to @PARAM/param.pck before falling back."""
    refused = ftp.answer(_ftp(4))  # OpenFileRO
    seq, _session, opcode, size, req_opcode = (
        refused.payload[0] | refused.payload[1] << 8,
        *(refused.payload[2:6]),
    )
    assert (seq, opcode, size, req_opcode, refused.payload[12]) == (8, ftp.NAK, 1, 4, 10)
    assert (refused.target_system, refused.target_component) == (255, 190)
    reset = ftp.answer(_ftp(ftp.RESET_SESSIONS))
    assert reset.payload[3] == ftp.ACK
