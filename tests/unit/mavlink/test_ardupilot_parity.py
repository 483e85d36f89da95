"""The simulated Copter against ArduPilot Copter 4.5 as a ground station sees it (issue 10, items
1-5), driven with plain pymavlink: each message is packed by pymavlink, fed to the vehicle's
endpoint as a datagram, and what the endpoint sends back is parsed by pymavlink again.

Before this change the vehicle ACKed an arm 3 s before it was armed, reported SYS_STATUS without
the geofence's health (MAVProxy: "fence breach") or a pre-arm bit (MAVSDK: not armable), had 21
parameters, left MAVFTP unanswered, refused partial mission writes, fences and rally points, and
read item 0 back as whatever was uploaded.
"""

from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import ardupilotmega as m

from dronefleet.sim.mavlink import ftp
from dronefleet.sim.mavlink.copter import SimCopter
from dronefleet.sim.mavlink.endpoint import VehicleEndpoint
from dronefleet.sim.mavlink.params import ParamTable
from dronefleet.sim.vehicle import SimVehicle
from unit.mavlink.test_ardupilot_behaviours import HOME
from unit.mavlink.test_ground_station_view import _Transport

FENCE, RALLY, MISSION = m.MAV_MISSION_TYPE_FENCE, m.MAV_MISSION_TYPE_RALLY, 0


class Gcs:
    """A pymavlink ground station wired to one vehicle endpoint through datagrams."""

    def __init__(self, **vehicle: float) -> None:
        self.copter = SimCopter(SimVehicle("Q", HOME, **vehicle), params=ParamTable())
        self.endpoint = VehicleEndpoint(self.copter, 1, "127.0.0.1", 0)
        self.transport = _Transport()
        self.endpoint._transport = self.transport  # type: ignore[assignment]
        self.mav = m.MAVLink(None, srcSystem=255, srcComponent=190)
        self.parser = m.MAVLink(None)
        self._read = 0

    def send(self, msg: m.MAVLink_message) -> list[m.MAVLink_message]:
        """Send ``msg``; what the vehicle answered at once (no vehicle time passes)."""
        self.endpoint.datagram_received(msg.pack(self.mav), ("127.0.0.1", 14550))
        return self.received()

    def received(self) -> list[m.MAVLink_message]:
        out = []
        for data, _ in self.transport.sent[self._read :]:
            out += self.parser.parse_buffer(data) or []
        self._read = len(self.transport.sent)
        return out

    def command(self, cmd: int, *p: float) -> list[m.MAVLink_message]:
        return self.send(
            m.MAVLink_command_long_message(1, 1, cmd, 0, *[*p, 0, 0, 0, 0, 0, 0, 0][:7])
        )

    def run(self, seconds: float, step: float = 0.05) -> None:
        for _ in range(round(seconds / step)):
            self.copter.vehicle.step(step)
            self.endpoint.update()
        self.received()

    def guided_at(self, altitude_m: float) -> None:
        self.command(m.MAV_CMD_DO_SET_MODE, m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4)  # GUIDED
        self.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        self.command(m.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, altitude_m)
        self.run(altitude_m / 2 + 4)

    def sys_status(self) -> m.MAVLink_sys_status_message:
        self.command(m.MAV_CMD_REQUEST_MESSAGE, m.MAVLINK_MSG_ID_SYS_STATUS)
        return [x for x in self.transport_log() if x.get_type() == "SYS_STATUS"][-1]

    def transport_log(self) -> list[m.MAVLink_message]:
        parser = m.MAVLink(None)
        return [x for data, _ in self.transport.sent for x in parser.parse_buffer(data) or []]


def of(kind: str, msgs: list[m.MAVLink_message]) -> list[m.MAVLink_message]:
    return [x for x in msgs if x.get_type() == kind]


# -- item 1: arming -------------------------------------------------------------------------------
def test_the_arm_ack_goes_out_armed_and_a_takeoff_right_after_it_is_accepted():
    gcs = Gcs()  # SimVehicle's own 3 s arming, which the ACK used to run ahead of
    gcs.command(m.MAV_CMD_DO_SET_MODE, m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4)
    answer = gcs.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    kinds = [x.get_type() for x in answer]
    ack = answer[kinds.index("COMMAND_ACK")]
    assert ack.result == m.MAV_RESULT_ACCEPTED
    beats = of("HEARTBEAT", answer[kinds.index("COMMAND_ACK") :])
    assert beats and beats[0].base_mode & m.MAV_MODE_FLAG_SAFETY_ARMED
    takeoff = gcs.command(m.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10)  # no time has passed
    assert of("COMMAND_ACK", takeoff)[0].result == m.MAV_RESULT_ACCEPTED
    gcs.run(3)
    assert gcs.copter.vehicle.relative_alt_m > 2


# -- item 2: SYS_STATUS ---------------------------------------------------------------------------
_HEALTHY = (
    m.MAV_SYS_STATUS_SENSOR_3D_GYRO | m.MAV_SYS_STATUS_SENSOR_3D_ACCEL
    | m.MAV_SYS_STATUS_SENSOR_3D_MAG | m.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
    | m.MAV_SYS_STATUS_SENSOR_GPS | m.MAV_SYS_STATUS_AHRS | m.MAV_SYS_STATUS_SENSOR_BATTERY
    | m.MAV_SYS_STATUS_PREARM_CHECK
)  # fmt: skip
_FENCE = m.MAV_SYS_STATUS_GEOFENCE
_PREARM = m.MAV_SYS_STATUS_PREARM_CHECK


def test_a_healthy_copter_is_armable_and_its_disabled_fence_is_not_breached():
    status = Gcs().sys_status()
    for bits in (status.onboard_control_sensors_present, status.onboard_control_sensors_enabled):
        assert bits & _HEALTHY == _HEALTHY
    assert status.onboard_control_sensors_health & _HEALTHY == _HEALTHY  # MAVSDK: is_armable
    assert status.onboard_control_sensors_present & _FENCE  # FENCE_TYPE 7: a fence is set up
    assert not status.onboard_control_sensors_enabled & _FENCE  # FENCE_ENABLE 0
    assert status.onboard_control_sensors_health & _FENCE  # not failing: no "fence breach"


def test_an_enabled_fence_shows_enabled_and_loses_its_health_when_breached():
    gcs = Gcs(arming_s=0)
    gcs.send(m.MAVLink_param_set_message(1, 1, b"FENCE_ENABLE", 1, m.MAV_PARAM_TYPE_INT8))
    gcs.send(m.MAVLink_param_set_message(1, 1, b"FENCE_ALT_MAX", 6, m.MAV_PARAM_TYPE_REAL32))
    status = gcs.sys_status()
    assert status.onboard_control_sensors_enabled & _FENCE
    assert status.onboard_control_sensors_health & _FENCE
    gcs.guided_at(10)
    assert not gcs.sys_status().onboard_control_sensors_health & _FENCE


def test_the_prearm_bit_follows_the_checks_and_arming_check():
    gcs = Gcs(initial_charge_pct=3)  # below the battery failsafe: pre-arm fails
    status = gcs.sys_status()
    assert status.onboard_control_sensors_enabled & _PREARM
    assert not status.onboard_control_sensors_health & _PREARM
    gcs.send(m.MAVLink_param_set_message(1, 1, b"ARMING_CHECK", 0, m.MAV_PARAM_TYPE_INT32))
    gcs.run(0.1)
    status = gcs.sys_status()
    assert not status.onboard_control_sensors_enabled & _PREARM
    assert status.onboard_control_sensors_health & _PREARM


# -- item 3: parameters and MAVFTP -----------------------------------------------------------------
_EXPECTED = {  # name: (ArduPilot Copter 4.5 default, MAV_PARAM_TYPE)
    "DISARM_DELAY": (10, m.MAV_PARAM_TYPE_INT8), "LAND_SPEED": (50, m.MAV_PARAM_TYPE_INT16),
    "LAND_SPEED_HIGH": (0, m.MAV_PARAM_TYPE_INT16), "LAND_ALT_LOW": (1000, m.MAV_PARAM_TYPE_INT16),
    "RTL_ALT": (1500, m.MAV_PARAM_TYPE_INT32), "RTL_LOIT_TIME": (5000, m.MAV_PARAM_TYPE_INT32),
    "RTL_SPEED": (0, m.MAV_PARAM_TYPE_INT16), "FLTMODE1": (0, m.MAV_PARAM_TYPE_INT8),
    "FLTMODE6": (0, m.MAV_PARAM_TYPE_INT8), "FLTMODE_CH": (5, m.MAV_PARAM_TYPE_INT8),
    "FENCE_ENABLE": (0, m.MAV_PARAM_TYPE_INT8), "FENCE_TYPE": (7, m.MAV_PARAM_TYPE_INT8),
    "FENCE_ACTION": (1, m.MAV_PARAM_TYPE_INT8), "FENCE_ALT_MAX": (100, m.MAV_PARAM_TYPE_REAL32),
    "FENCE_RADIUS": (300, m.MAV_PARAM_TYPE_REAL32), "FENCE_MARGIN": (2, m.MAV_PARAM_TYPE_REAL32),
    "BATT_LOW_VOLT": (10.5, m.MAV_PARAM_TYPE_REAL32), "BATT_CRT_VOLT": (0, m.MAV_PARAM_TYPE_REAL32),
    "BATT_FS_CRT_ACT": (0, m.MAV_PARAM_TYPE_INT8), "WPNAV_SPEED": (1000, m.MAV_PARAM_TYPE_REAL32),
    "WPNAV_ACCEL": (250, m.MAV_PARAM_TYPE_REAL32), "WPNAV_RADIUS": (200, m.MAV_PARAM_TYPE_REAL32),
    "WPNAV_SPEED_DN": (150, m.MAV_PARAM_TYPE_REAL32), "ANGLE_MAX": (3000, m.MAV_PARAM_TYPE_INT16),
    "PILOT_SPEED_UP": (250, m.MAV_PARAM_TYPE_INT16), "ARMING_CHECK": (1, m.MAV_PARAM_TYPE_INT32),
    "SYSID_THISMAV": (1, m.MAV_PARAM_TYPE_INT16), "SERIAL1_BAUD": (57, m.MAV_PARAM_TYPE_INT32),
    "SR0_POSITION": (0, m.MAV_PARAM_TYPE_INT16), "INS_GYRO_FILTER": (20, m.MAV_PARAM_TYPE_INT16),
    "COMPASS_USE": (1, m.MAV_PARAM_TYPE_INT8), "EK3_ENABLE": (1, m.MAV_PARAM_TYPE_INT8),
}  # fmt: skip


def test_the_whole_parameter_list_comes_at_once_with_ardupilots_names_and_defaults():
    gcs = Gcs()
    answer = of("PARAM_VALUE", gcs.send(m.MAVLink_param_request_list_message(1, 1)))
    params = {x.param_id: x for x in answer}  # all of them before any vehicle time passes
    count = answer[0].param_count
    assert count >= 300 and len(params) == count == len(answer)
    assert sorted(x.param_index for x in answer) == list(range(count))
    assert len(gcs.transport.sent) < count / 10  # several to a datagram: no buffer overflows
    for name, (value, kind) in _EXPECTED.items():
        assert (params[name].param_value, params[name].param_type) == (value, kind), name


def test_parameters_the_sim_flies_by_still_change_how_it_flies():
    gcs = Gcs()
    echo = gcs.send(m.MAVLink_param_set_message(1, 1, b"WPNAV_SPEED", 500, 9))
    assert [(x.param_id, x.param_value) for x in of("PARAM_VALUE", echo)] == [("WPNAV_SPEED", 500)]
    assert gcs.copter.vehicle.limits.max_speed_mps == 5.0


@pytest.mark.parametrize(
    ("opcode", "reply", "error"),
    [(ftp.OPEN_FILE_RO, ftp.NAK, ftp.ERR_FILE_NOT_FOUND), (ftp.LIST_DIRECTORY, ftp.NAK, 10),
     (ftp.RESET_SESSIONS, ftp.ACK, 0)],
)  # fmt: skip
def test_mavftp_is_answered_at_once_so_ground_stations_fall_back_to_the_list(opcode, reply, error):
    path = b"@PARAM/param.pck"
    header = bytes([5, 0, 0, opcode, len(path), 0, 0, 0]) + bytes(4)  # seq 5, session 0
    payload = list((header + path).ljust(251, b"\0"))
    answer = Gcs().send(m.MAVLink_file_transfer_protocol_message(0, 1, 1, payload))
    (msg,) = of("FILE_TRANSFER_PROTOCOL", answer)
    seq, got, size, req_opcode, first = ftp.reply_fields(msg)
    assert (seq, got, req_opcode) == (6, reply, opcode)
    assert (first if size else 0) == error
    assert msg.target_system == 255


# -- item 4: missions, fences, rally points -------------------------------------------------------
def _item(seq: int, cmd: int, lat: float, lon: float, z: float, kind: int = MISSION, p1: float = 0):
    return m.MAVLink_mission_item_int_message(
        1, 1, seq, m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, cmd, 0, 1, p1, 0, 0, 0,
        round(lat * 1e7), round(lon * 1e7), z, kind,
    )  # fmt: skip


def _serve(gcs: Gcs, answer: list, items: dict[int, m.MAVLink_message]) -> tuple[list[int], int]:
    """Answer the vehicle's item requests from ``items``; (seqs asked, MISSION_ACK type)."""
    asked: list[int] = []
    while not of("MISSION_ACK", answer):
        (request,) = of("MISSION_REQUEST_INT", answer)
        asked.append(request.seq)
        answer = gcs.send(items[request.seq])
    return asked, of("MISSION_ACK", answer)[0].type


def _upload(gcs: Gcs, items: list[m.MAVLink_message], kind: int = MISSION) -> int:
    answer = gcs.send(m.MAVLink_mission_count_message(1, 1, len(items), kind))
    return _serve(gcs, answer, dict(enumerate(items)))[1]


def _download(gcs: Gcs, kind: int = MISSION) -> list[m.MAVLink_message]:
    (count,) = of("MISSION_COUNT", gcs.send(m.MAVLink_mission_request_list_message(1, 1, kind)))
    assert count.mission_type == kind
    got = [
        gcs.send(m.MAVLink_mission_request_int_message(1, 1, s, kind)) for s in range(count.count)
    ]
    return [of("MISSION_ITEM_INT", answer)[0] for answer in got]


def _waypoints(n: int, z: float = 10) -> list[m.MAVLink_message]:
    home = _item(0, m.MAV_CMD_NAV_WAYPOINT, 0, 0, 0)  # what QGroundControl puts there
    return [home] + [
        _item(s, m.MAV_CMD_NAV_WAYPOINT, HOME.lat + s * 1e-4, HOME.lon, z) for s in range(1, n)
    ]


def test_item_0_reads_back_as_home_even_for_an_empty_mission():
    gcs = Gcs()
    (home,) = _download(gcs)  # ArduPilot's mission always has home
    assert _upload(gcs, _waypoints(3)) == m.MAV_MISSION_ACCEPTED
    items = _download(gcs)
    assert len(items) == 3 and items[0].seq == 0
    for item in (home, items[0]):
        assert (item.x, item.y) == (round(HOME.lat * 1e7), round(HOME.lon * 1e7))
        assert item.z == pytest.approx(HOME.alt_m)
    assert items[2].x == round((HOME.lat + 2e-4) * 1e7)


def test_a_partial_write_replaces_only_items_start_to_end():
    gcs = Gcs()
    _upload(gcs, _waypoints(4))
    new = {s: _item(s, m.MAV_CMD_NAV_WAYPOINT, HOME.lat, HOME.lon + s * 1e-4, 30) for s in (2, 3)}
    answer = gcs.send(m.MAVLink_mission_write_partial_list_message(1, 1, 2, 3, MISSION))
    assert _serve(gcs, answer, new) == ([2, 3], m.MAV_MISSION_ACCEPTED)
    items = _download(gcs)
    assert [it.z for it in items[1:]] == [10, 30, 30]
    assert items[3].y == round((HOME.lon + 3e-4) * 1e7)
    bad = gcs.send(m.MAVLink_mission_write_partial_list_message(1, 1, 3, 9, MISSION))
    assert of("MISSION_ACK", bad)[0].type == m.MAV_MISSION_ERROR


def test_fence_and_rally_points_are_stored_read_back_and_cleared_apart_from_the_mission():
    gcs = Gcs()
    vertex = m.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
    corners = [(0, 0), (0, 1), (1, 1), (1, 0)]
    fence = [
        _item(s, vertex, HOME.lat + a * 1e-3, HOME.lon + b * 1e-3, 0, FENCE, p1=4)
        for s, (a, b) in enumerate(corners)
    ]
    rally = [_item(s, m.MAV_CMD_NAV_RALLY_POINT, HOME.lat, HOME.lon, 20, RALLY) for s in (0, 1)]
    _upload(gcs, _waypoints(3))
    assert _upload(gcs, fence, FENCE) == m.MAV_MISSION_ACCEPTED
    assert _upload(gcs, rally, RALLY) == m.MAV_MISSION_ACCEPTED
    got = _download(gcs, FENCE)
    assert [(it.command, it.x, it.y, it.mission_type) for it in got] == [
        (vertex, f.x, f.y, FENCE) for f in fence
    ]
    assert len(_download(gcs, RALLY)) == 2 and len(_download(gcs)) == 3
    assert gcs.copter.params.get("FENCE_TOTAL") == 4 and gcs.copter.params.get("RALLY_TOTAL") == 2
    cleared = gcs.send(m.MAVLink_mission_clear_all_message(1, 1, FENCE))
    assert (of("MISSION_ACK", cleared)[0].type, of("MISSION_ACK", cleared)[0].mission_type) == (
        m.MAV_MISSION_ACCEPTED, FENCE,
    )  # fmt: skip
    assert _download(gcs, FENCE) == [] and len(_download(gcs, RALLY)) == 2
    assert len(_download(gcs)) == 3


# -- item 5: landing ------------------------------------------------------------------------------
def _land(gcs: Gcs) -> tuple[float, float]:
    """LAND from where it is: (vehicle seconds to touch down, seconds more until disarmed)."""
    gcs.command(m.MAV_CMD_NAV_LAND)
    v, t0 = gcs.copter.vehicle, gcs.copter.vehicle.time_s
    while v.in_air and v.time_s - t0 < 90:
        gcs.run(0.05)
    down = v.time_s
    while v.armed and v.time_s - down < 30:
        gcs.run(0.05)
    return down - t0, v.time_s - down


def test_landing_from_10_m_takes_ardupilots_time_and_the_land_detector_disarms():
    gcs = Gcs()
    gcs.guided_at(10)
    descent_s, disarm_s = _land(gcs)
    assert 18 <= descent_s <= 22  # all below LAND_ALT_LOW (10 m): LAND_SPEED, 0.5 m/s
    assert 0.9 <= disarm_s <= 1.5  # ModeLand disarms on land_complete, not after DISARM_DELAY
    beat = of("HEARTBEAT", gcs.transport_log())[-1]
    assert not beat.base_mode & m.MAV_MODE_FLAG_SAFETY_ARMED and beat.custom_mode == 9  # LAND


@pytest.mark.parametrize(("land_speed_high", "expected_s"), [(0, 33.3), (300, 26.7)])
def test_above_land_alt_low_it_descends_at_land_speed_high_or_wpnav_speed_dn(
    land_speed_high, expected_s
):
    gcs = Gcs()
    gcs.send(m.MAVLink_param_set_message(1, 1, b"LAND_SPEED_HIGH", land_speed_high, 4))
    gcs.guided_at(30)
    descent_s, _ = _land(gcs)  # 20 m at 1.5 (or 3) m/s, then 10 m at 0.5 m/s
    assert descent_s == pytest.approx(expected_s, abs=1.5)
