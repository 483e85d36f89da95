"""Commands the simulated Copter serves: COMMAND_LONG / COMMAND_INT, SET_MODE and GUIDED position
targets (SET_POSITION_TARGET_GLOBAL_INT), answered the way ArduPilot answers them.

Each command yields a MAV_RESULT and, when refused, the reason the endpoint sends as STATUSTEXT
just before the COMMAND_ACK — so a ground station (or our MAVLink backend) can tell the operator
*why* (e.g. "Arm: battery at 3.0 % …"). Magic values are ArduPilot's: 2989 forces an arm, 21196
forces a disarm in flight, 20190226 forces a reboot while armed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import LLA, NED
from dronefleet.protocols.mavlink.codec import Message
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.modes import CopterMode
from dronefleet.sim.mavlink.copter import CommandRefused

if TYPE_CHECKING:
    from dronefleet.sim.mavlink.endpoint import VehicleEndpoint

FORCE_ARM = 2989
FORCE_DISARM = 21196
FORCE_REBOOT = 20190226
_IGNORE_POSITION = 0b111  # type_mask bits: x, y, z ignored
_IGNORE_VELOCITY = 0b111000  # vx, vy, vz ignored
_BODY_FRAMES = frozenset({mav.MAV_FRAME_BODY_NED, mav.MAV_FRAME_BODY_OFFSET_NED})
_LOCAL_FRAMES = frozenset({mav.MAV_FRAME_LOCAL_NED, mav.MAV_FRAME_LOCAL_OFFSET_NED, *_BODY_FRAMES})
_ABSOLUTE_FRAMES = {mav.MAV_FRAME_GLOBAL, mav.MAV_FRAME_GLOBAL_INT}

Params = list[float]  # param1..param7 (param5/6 in degrees, param7 metres)


class CommandHandler:
    """Turns command messages into actions on one :class:`~.copter.SimCopter`."""

    def __init__(self, endpoint: VehicleEndpoint) -> None:
        self.endpoint = endpoint
        self.copter = endpoint.copter
        m = mav
        self._table: dict[int, Callable[[Params, int], int]] = {
            m.MAV_CMD_COMPONENT_ARM_DISARM: self._arm_disarm,
            m.MAV_CMD_NAV_TAKEOFF: lambda p, f: self._do(self.copter.takeoff, p[6]),
            m.MAV_CMD_NAV_LAND: lambda p, f: self._do(self.copter.set_mode, CopterMode.LAND),
            m.MAV_CMD_NAV_RETURN_TO_LAUNCH: lambda p, f: self._do(
                self.copter.set_mode, CopterMode.RTL
            ),
            m.MAV_CMD_DO_SET_MODE: self._set_mode,
            m.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: self._reboot,
            m.MAV_CMD_SET_MESSAGE_INTERVAL: self._set_interval,
            m.MAV_CMD_GET_MESSAGE_INTERVAL: self._get_interval,
            m.MAV_CMD_REQUEST_MESSAGE: self._request_message,
            m.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: lambda p, f: self._send_version(),
            m.MAV_CMD_MISSION_START: self._mission_start,
            m.MAV_CMD_DO_SET_MISSION_CURRENT: self._set_current,
            m.MAV_CMD_IMAGE_START_CAPTURE: lambda p, f: self._picture(),
            m.MAV_CMD_DO_DIGICAM_CONTROL: lambda p, f: self._picture() if p[4] == 1 else 0,
            m.MAV_CMD_DO_SET_CAM_TRIGG_DIST: self._trigger_distance,
            m.MAV_CMD_DO_REPOSITION: self._reposition,
            m.MAV_CMD_DO_CHANGE_SPEED: self._change_speed,
            m.MAV_CMD_GET_HOME_POSITION: lambda p, f: self._send_now(
                m.MAVLINK_MSG_ID_HOME_POSITION
            ),
        }

    # -- COMMAND_LONG / COMMAND_INT ---------------------------------------------------------------
    def command(self, msg: Message) -> tuple[int, str | None]:
        """Run a COMMAND_LONG or COMMAND_INT; returns (MAV_RESULT, reason for a refusal)."""
        if msg.get_type() == "COMMAND_INT":
            params = [
                msg.param1,
                msg.param2,
                msg.param3,
                msg.param4,
                msg.x / 1e7,
                msg.y / 1e7,
                msg.z,
            ]
            frame = msg.frame
        else:
            params = [
                msg.param1,
                msg.param2,
                msg.param3,
                msg.param4,
                msg.param5,
                msg.param6,
                msg.param7,
            ]
            frame = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT
        handler = self._table.get(msg.command)
        if handler is None:
            return mav.MAV_RESULT_UNSUPPORTED, None
        try:
            return handler(params, frame), None
        except CommandRefused as exc:
            return exc.result, exc.reason

    def _send_now(self, msg_id: int) -> int:
        """A message sent at once (ArduPilot answers GET_HOME_POSITION so, issue 10 item 9)."""
        return mav.MAV_RESULT_ACCEPTED if self.endpoint.send_now(msg_id) else mav.MAV_RESULT_FAILED

    def _do(self, action: Callable[..., object], *args: object) -> int:
        action(*args)
        return mav.MAV_RESULT_ACCEPTED

    def _arm_disarm(self, p: Params, frame: int) -> int:
        if p[0] == 1:
            self.copter.arm(force=p[1] == FORCE_ARM)
        else:
            self.copter.disarm(force=p[1] == FORCE_DISARM)
        return mav.MAV_RESULT_ACCEPTED

    def _set_mode(self, p: Params, frame: int) -> int:
        if not int(p[0]) & mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            raise CommandRefused("Mode change failed: use custom modes", mav.MAV_RESULT_DENIED)
        self.copter.set_mode(int(p[1]))
        return mav.MAV_RESULT_ACCEPTED

    def _reboot(self, p: Params, frame: int) -> int:
        if p[0] != 1:
            return mav.MAV_RESULT_UNSUPPORTED
        self.copter.reboot(force=p[5] == FORCE_REBOOT)
        return mav.MAV_RESULT_ACCEPTED

    def _set_interval(self, p: Params, frame: int) -> int:
        ok = self.endpoint.streams.set_interval(int(p[0]), p[1])
        return mav.MAV_RESULT_ACCEPTED if ok else mav.MAV_RESULT_DENIED

    def _get_interval(self, p: Params, frame: int) -> int:
        msg_id = int(p[0])
        interval = self.endpoint.streams.interval_us(msg_id)
        self.endpoint.send(mav.MAVLink_message_interval_message(msg_id, interval))
        return mav.MAV_RESULT_ACCEPTED

    def _request_message(self, p: Params, frame: int) -> int:
        msg_id = int(p[0])
        if msg_id == mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            return self._send_version()
        sent = self.endpoint.send_now(msg_id)
        return mav.MAV_RESULT_ACCEPTED if sent else mav.MAV_RESULT_DENIED

    def _send_version(self) -> int:
        caps = (
            mav.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
            | mav.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
            | mav.MAV_PROTOCOL_CAPABILITY_MISSION_INT
            | mav.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
            | mav.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
            | mav.MAV_PROTOCOL_CAPABILITY_MAVLINK2
        )
        version = (4 << 24) | (5 << 16) | (0 << 8) | 255  # "4.5.0 official", as ArduPilot packs it
        self.endpoint.send(
            mav.MAVLink_autopilot_version_message(
                caps, version, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, self.endpoint.system_id
            )
        )
        return mav.MAV_RESULT_ACCEPTED

    def _mission_start(self, p: Params, frame: int) -> int:
        # Copter denies a first/last item (GCS_MAVLink_Copter.cpp, MAV_CMD_MISSION_START: "first-
        # item/last item not supported"); it starts or resumes at the current item, which
        # DO_SET_MISSION_CURRENT chooses.
        if p[0] != 0 or p[1] != 0:
            raise CommandRefused(None, mav.MAV_RESULT_DENIED)
        copter = self.copter
        if len(copter.mission) <= 1:
            raise CommandRefused("Mission: no mission to start")
        copter.start_mission()
        return mav.MAV_RESULT_ACCEPTED

    def _set_current(self, p: Params, frame: int) -> int:
        seq = int(p[0])
        if not 0 <= seq < len(self.copter.mission):
            raise CommandRefused(f"Mission: no item {seq}", mav.MAV_RESULT_DENIED)
        self.copter.runner.set_current(seq)
        return mav.MAV_RESULT_ACCEPTED

    def _picture(self) -> int:
        # No camera configured (CAM1_TYPE 0): SITL answers FAILED (issue 17).
        info = self.copter.take_picture()
        return mav.MAV_RESULT_ACCEPTED if info is not None else mav.MAV_RESULT_FAILED

    def _trigger_distance(self, p: Params, frame: int) -> int:
        if self.copter.camera is None:
            return mav.MAV_RESULT_FAILED
        self.copter.trigger.set_distance(p[0], shoot_now=p[2] == 1)
        return mav.MAV_RESULT_ACCEPTED

    def _reposition(self, p: Params, frame: int) -> int:
        if int(p[1]) & mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE:
            self.copter.set_mode(CopterMode.GUIDED)
        self.copter.guided_target(self._ned(p[4], p[5], p[6], frame))
        return mav.MAV_RESULT_ACCEPTED

    def _change_speed(self, p: Params, frame: int) -> int:
        self.copter.set_speed(p[1])
        return mav.MAV_RESULT_ACCEPTED

    # -- SET_MODE and GUIDED targets ----------------------------------------------------------
    def set_mode_message(self, msg: Message) -> tuple[int, str | None]:
        try:
            return self._set_mode([msg.base_mode, msg.custom_mode, 0, 0, 0, 0, 0], 0), None
        except CommandRefused as exc:
            return exc.result, exc.reason

    def position_target(self, msg: Message) -> str | None:
        """Fly to a SET_POSITION_TARGET_GLOBAL_INT target (a position, else a velocity in
        north-east-down); returns the refusal, if any."""
        try:
            if not msg.type_mask & _IGNORE_POSITION:
                self.copter.guided_target(
                    self._ned(msg.lat_int / 1e7, msg.lon_int / 1e7, msg.alt, msg.coordinate_frame)
                )
            elif not msg.type_mask & _IGNORE_VELOCITY:
                self.copter.guided_velocity(NED(msg.vx, msg.vy, msg.vz))
            else:
                return "Guided: the target has neither a position nor a velocity"
        except CommandRefused as exc:
            return exc.reason
        return None

    def local_target(self, msg: Message) -> str | None:
        """SET_POSITION_TARGET_LOCAL_NED: a position (from home in MAV_FRAME_LOCAL_NED, from the
        vehicle in the OFFSET and BODY frames) or, without one, a velocity; BODY frames turn
        with the vehicle's heading (x forward, y right), as ArduCopter's GCS_Mavlink.cpp does."""
        frame = msg.coordinate_frame
        if frame not in _LOCAL_FRAMES:
            return f"Guided: frame {frame} is not supported for local targets"
        v = self.copter.vehicle
        x, y = msg.x, msg.y
        vx, vy = msg.vx, msg.vy
        if frame in _BODY_FRAMES:
            yaw = math.radians(v.attitude.yaw_deg)
            x, y = x * math.cos(yaw) - y * math.sin(yaw), x * math.sin(yaw) + y * math.cos(yaw)
            vx, vy = (
                vx * math.cos(yaw) - vy * math.sin(yaw),
                vx * math.sin(yaw) + vy * math.cos(yaw),
            )
        try:
            if not msg.type_mask & _IGNORE_POSITION:
                here = v.position_ned if frame != mav.MAV_FRAME_LOCAL_NED else NED(0, 0, 0)
                self.copter.guided_target(NED(here.n + x, here.e + y, here.d + msg.z))
            elif not msg.type_mask & _IGNORE_VELOCITY:
                self.copter.guided_velocity(NED(vx, vy, msg.vz))
            else:
                return "Guided: the target has neither a position nor a velocity"
        except CommandRefused as exc:
            return exc.reason
        return None

    def _ned(self, lat: float, lon: float, alt: float, frame: int) -> NED:
        v = self.copter.vehicle
        home = v.home
        relative = alt - home.alt_m if frame in _ABSOLUTE_FRAMES else alt
        if not (math.isfinite(lat) and math.isfinite(lon)) or (lat == 0 and lon == 0):
            here = v.position_ned
            return NED(here.n, here.e, -relative)
        try:
            ned = lla_to_ned(LLA(lat, lon, home.alt_m), home)
        except ValueError as exc:
            raise CommandRefused(f"Guided: bad target ({exc})", mav.MAV_RESULT_DENIED) from None
        return NED(ned.n, ned.e, -relative)
