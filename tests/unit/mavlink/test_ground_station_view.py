"""What a ground station sees of the simulated Copter, as of ArduPilot Copter (issue 10).

Item 8: streams go on to a ground station that has gone quiet (they stopped 9.9 s after it
stopped sending). Item 9: MAV_CMD_GET_HOME_POSITION is answered with HOME_POSITION (it was
UNSUPPORTED), and MISSION_CLEAR_ALL is refused while the vehicle flies its mission in AUTO (it was
accepted).
"""

from __future__ import annotations

from dronefleet.clock import monotonic
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.items import MissionItem
from dronefleet.protocols.mavlink.modes import CopterMode
from dronefleet.sim.mavlink.endpoint import VehicleEndpoint
from dronefleet.sim.mavlink.handlers import CommandHandler
from dronefleet.sim.mavlink.transfer import MissionTransfer
from unit.mavlink.test_ardupilot_behaviours import HOME, make, run


class _Transport:
    def __init__(self) -> None:
        self.sent: list[tuple[bytes, tuple[str, int]]] = []

    def sendto(self, data: bytes, addr: tuple[str, int]) -> None:
        self.sent.append((data, addr))


def test_streams_go_on_to_a_ground_station_that_has_gone_quiet():
    endpoint = VehicleEndpoint(make(), 1, "127.0.0.1", 0)
    transport = _Transport()
    endpoint._transport = transport  # type: ignore[assignment]
    quiet = ("127.0.0.1", 14550)
    endpoint.peers[quiet] = monotonic() - 3600.0  # heard an hour ago, silent since
    endpoint.send_now(mav.MAVLINK_MSG_ID_HEARTBEAT)
    assert [addr for _, addr in transport.sent] == [quiet]


class _Endpoint:
    def __init__(self) -> None:
        self.copter = make()
        self.now: list[int] = []

    def send_now(self, msg_id: int) -> bool:
        self.now.append(msg_id)
        return True


def test_get_home_position_is_answered_with_home_position():
    endpoint = _Endpoint()
    handler = CommandHandler(endpoint)  # type: ignore[arg-type]
    msg = mav.MAVLink_command_long_message(
        1, 1, mav.MAV_CMD_GET_HOME_POSITION, 0, 0, 0, 0, 0, 0, 0, 0
    )
    assert handler.command(msg) == (mav.MAV_RESULT_ACCEPTED, None)
    assert endpoint.now == [mav.MAVLINK_MSG_ID_HOME_POSITION]


def test_the_mission_being_flown_cannot_be_cleared():
    copter = make()
    acks: list[int] = []
    transfer = MissionTransfer(copter, lambda m: acks.append(m.type))
    north = int((HOME.lat + 0.001) * 1e7)
    home = MissionItem(mav.MAV_CMD_NAV_WAYPOINT)  # item 0 is home, as ArduPilot keeps it
    waypoint = MissionItem(mav.MAV_CMD_NAV_WAYPOINT, x=north, y=int(HOME.lon * 1e7), z=10)
    copter.on_mission_replaced([home, waypoint])
    copter.set_mode(CopterMode.GUIDED)
    copter.arm()
    copter.takeoff(10)
    run(copter, 3)
    copter.start_mission()
    clear = mav.MAVLink_mission_clear_all_message(1, 1)
    clear._header = mav.MAVLink_header(0, 0, 0, srcSystem=255, srcComponent=0)
    transfer.handle(clear)
    assert acks == [mav.MAV_MISSION_DENIED]
    copter.set_mode(CopterMode.LOITER)  # not flying the mission: clearing is fine
    transfer.handle(clear)
    assert acks[-1] == mav.MAV_MISSION_ACCEPTED


def test_a_speed_change_lasts_until_the_mode_changes():
    """Item 7: DO_CHANGE_SPEED rewrote WPNAV_SPEED for good and carried into later GUIDED flight."""
    endpoint = _Endpoint()
    copter = endpoint.copter
    handler = CommandHandler(endpoint)  # type: ignore[arg-type]
    default = copter.vehicle.limits.max_speed_mps
    copter.set_mode(CopterMode.GUIDED)
    msg = mav.MAVLink_command_long_message(
        1, 1, mav.MAV_CMD_DO_CHANGE_SPEED, 0, 1, 3, -1, 0, 0, 0, 0
    )
    assert handler.command(msg) == (mav.MAV_RESULT_ACCEPTED, None)
    assert copter.vehicle.limits.max_speed_mps == 3
    assert copter.params.get("WPNAV_SPEED") == default * 100  # the parameter is untouched
    copter.set_mode(CopterMode.LOITER)
    copter.set_mode(CopterMode.GUIDED)
    assert copter.vehicle.limits.max_speed_mps == default
