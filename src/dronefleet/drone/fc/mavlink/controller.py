"""The ``mavlink`` flight-controller backend: the FlightController protocol over MAVLink
(Flight Controller Interface, seed 3.3.2.2 / 4.1.2.1; docs/DESIGN.md §5).

ArduPilot Copter semantics: commands fly in GUIDED — arming with MAV_CMD_COMPONENT_ARM_DISARM,
MAV_CMD_NAV_TAKEOFF (altitude above home), SET_POSITION_TARGET_GLOBAL_INT position targets — and
LAND, RTL and BRAKE are mode changes. PX4 differs where it matters: no GUIDED (OFFBOARD needs a
setpoint stream), so targets go as MAV_CMD_DO_REPOSITION in AUTO.LOITER and NAV_TAKEOFF takes an
altitude above mean sea level (see :mod:`.modes`). Every command waits for its COMMAND_ACK with
retries and a refusal raises :class:`FcError` with the autopilot's STATUSTEXT reason. State getters
read the latest messages and never block. The :attr:`clock` is the autopilot's (``time_boot_ms``).
Whole missions are flown on board through :attr:`mission` (:class:`.mission.MissionClient`).
"""

from __future__ import annotations

import asyncio
import logging
import math
from typing import Any

from dronefleet.clock import monotonic
from dronefleet.drone.fc.clock import AutopilotClock
from dronefleet.drone.fc.mavlink import objects, session
from dronefleet.drone.fc.mavlink.commands import CommandSender
from dronefleet.drone.fc.mavlink.link import LinkLost, MavlinkLink
from dronefleet.drone.fc.mavlink.mission import MissionClient
from dronefleet.drone.fc.mavlink.state import VehicleView, is_armed
from dronefleet.geo.types import LLA
from dronefleet.protocols.mavlink.codec import Message, text_field
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.modes import (
    Autopilot,
    custom_mode_for,
    set_mode_params,
)
from dronefleet.vehicle.base import FcError, FlightMode

log = logging.getLogger(__name__)

#: Message rates asked for on connect (Hz of vehicle time).
DEFAULT_STREAMS_HZ = {
    "GLOBAL_POSITION_INT": 10.0,
    "ATTITUDE": 10.0,
    "GPS_RAW_INT": 5.0,
    "SYS_STATUS": 2.0,
    "BATTERY_STATUS": 1.0,
    "EXTENDED_SYS_STATE": 2.0,
    "SYSTEM_TIME": 1.0,
    "HOME_POSITION": 0.5,
    "MISSION_CURRENT": 1.0,
    # The echo of each GUIDED target, which confirms it (ArduPilot sends it only when asked).
    "POSITION_TARGET_GLOBAL_INT": 4.0,
}
MIN_TARGET_ALT_M = 0.5
#: Autopilot parameters read on connect, for the planner's estimates and the gear check: key in
#: Heartbeat.flight, then ArduPilot Copter's names with the factor to SI units. Recent ArduPilot
#: (the SITL this project tests, upstream 64a9c78) names them in SI units (WP_SPD m/s, WP_ACC
#: m/s², WP_JERK m/s³, LAND_SPD_MS, LAND_ALT_LOW_M); earlier versions in cm (WPNAV_SPEED cm/s,
#: WPNAV_ACCEL cm/s², LAND_SPEED, LAND_ALT_LOW cm). The first name the autopilot knows wins.
FLIGHT_PARAMS: tuple[tuple[str, tuple[tuple[str, float], ...]], ...] = (
    ("speed_mps", (("WP_SPD", 1.0), ("WPNAV_SPEED", 0.01))),
    ("accel_mps2", (("WP_ACC", 1.0), ("WPNAV_ACCEL", 0.01))),
    ("accel_z_mps2", (("WP_ACC_Z", 1.0), ("WPNAV_ACCEL_Z", 0.01))),
    ("jerk_mps3", (("WP_JERK", 1.0), ("WPNAV_JERK", 1.0))),
    ("climb_mps", (("WP_SPD_UP", 1.0), ("WPNAV_SPEED_UP", 0.01))),
    ("descent_mps", (("WP_SPD_DN", 1.0), ("WPNAV_SPEED_DN", 0.01))),
    ("land_speed_mps", (("LAND_SPD_MS", 1.0), ("LAND_SPEED", 0.01))),
    ("land_alt_low_m", (("LAND_ALT_LOW_M", 1.0), ("LAND_ALT_LOW", 0.01))),
    ("capacity_mah", (("BATT_CAPACITY", 1.0),)),
    ("camera_type", (("CAM1_TYPE", 1.0),)),
)
#: ArduPilot's "really" values: disarm in flight, reboot while armed.
FORCE_DISARM_MAGIC = 21196
FORCE_REBOOT_MAGIC = 20190226
_POSITION_ONLY = 0b0000_1101_1111_1000  # SET_POSITION_TARGET type_mask: use lat/lon/alt only
_IN_AIR_STATES = {
    mav.MAV_LANDED_STATE_IN_AIR,
    mav.MAV_LANDED_STATE_TAKEOFF,
    mav.MAV_LANDED_STATE_LANDING,
}


#: How recent (wall seconds) a failsafe STATUSTEXT must be to explain a mode change.
FAILSAFE_TEXT_S = 3.0


class MavlinkFlightController(VehicleView):
    """FlightController for the autopilot at ``url`` (``udpout:HOST:PORT``, ``tcp:…``, a serial
    device)."""

    def __init__(
        self,
        url: str,
        *,
        telemetry_rate_hz: float = 5.0,
        heartbeat_timeout_s: float = 3.0,
        ack_timeout_s: float = 1.0,
        retries: int = 3,
        target_system: int | None = None,
        streams_hz: dict[str, float] | None = None,
        connect_timeout_s: float = 15.0,
        signing_key: bytes | None = None,
    ) -> None:
        if telemetry_rate_hz <= 0:
            raise ValueError("telemetry rate must be positive")
        self.url = url
        self.telemetry_rate_hz = telemetry_rate_hz
        self.connect_timeout_s = connect_timeout_s
        self.streams_hz = dict(DEFAULT_STREAMS_HZ if streams_hz is None else streams_hz)
        self.link = MavlinkLink(
            url,
            target_system=target_system,
            heartbeat_timeout_s=heartbeat_timeout_s,
            signing_key=signing_key,
        )
        self.commands = CommandSender(self.link, ack_timeout_s=ack_timeout_s, retries=retries)
        self._clock = AutopilotClock()
        self.autopilot = Autopilot.GENERIC
        self.mission = MissionClient(self.link, self.commands, self.autopilot, self._clock)
        self.named_values: dict[str, tuple[float, float]] = {}  # name -> (value, vehicle s)
        self.captures: list[dict[str, Any]] = []
        self.rebooting = False
        self._arming = False
        self._connected = False
        self._closed = False
        self._capacity_mah = 0.0
        self.params: dict[str, float] = {}  # FLIGHT_PARAMS the autopilot answered, in SI units
        self._background: set[asyncio.Task[Any]] = set()
        self.link.add_listener(self._on_message)
        self.link.on_link_change(self._on_link_change)

    @property
    def clock(self) -> AutopilotClock:
        return self._clock

    @property
    def connected(self) -> bool:
        return self._connected and self.link.link_ok

    # -- connection -----------------------------------------------------------------------------
    async def connect(self) -> None:
        """Open the link, wait for the autopilot, set stream rates, learn home. Idempotent."""
        if self._connected:
            return
        self._closed = False
        await self.link.open()
        try:
            beat = self.link.latest.get("HEARTBEAT") or await self.link.wait_for(
                "HEARTBEAT", timeout_s=self.connect_timeout_s
            )
            if beat is None:
                raise FcError(
                    f"no autopilot heartbeat on {self.url} in {self.connect_timeout_s:g} s"
                )
            self.autopilot = self.mission.autopilot = Autopilot.from_heartbeat(beat.autopilot)
            await self.request_streams()
            await session.learn_home(self.commands)
            self.params = await session.read_params(self.link, FLIGHT_PARAMS)
            self._capacity_mah = self.params.get("capacity_mah") or 0.0
        except BaseException:
            await self.link.close()
            raise
        self._connected = True
        log.info(
            "connected to %s autopilot %s on %s",
            self.autopilot.value,
            self.link.target_system,
            self.url,
        )

    async def close(self) -> None:
        self._closed = True
        self._connected = False
        for task in list(self._background):
            task.cancel()
        await self.link.close()

    async def request_streams(self) -> None:
        """Ask for our message rates again (after a reboot, or when the link comes back)."""
        await session.request_streams(self.commands, self.streams_hz)

    def _on_message(self, msg: Message) -> None:
        stamp = getattr(msg, "time_boot_ms", None)
        if stamp is not None:
            self._clock.observe(stamp)
        kind = msg.get_type()
        if kind == "NAMED_VALUE_FLOAT":
            self.named_values[text_field(msg.name)] = (msg.value, self._clock.now())
        elif kind == "CAMERA_IMAGE_CAPTURED":
            self.captures.append(
                {
                    "index": msg.image_index,
                    "lat": msg.lat / 1e7,
                    "lon": msg.lon / 1e7,
                    "alt_m": msg.alt / 1000.0,
                    "relative_alt_m": msg.relative_alt / 1000.0,
                    "vehicle_time_s": msg.time_boot_ms / 1000.0,
                    "file": text_field(msg.file_url) or None,
                    "ok": msg.capture_result == 1,
                }
            )

    def _on_link_change(self, ok: bool) -> None:
        if ok and self._connected and not self._closed:
            # The autopilot may have rebooted or forgotten our rates while we were apart.
            self._spawn(self.request_streams())

    def _spawn(self, coro) -> None:
        task = asyncio.get_running_loop().create_task(coro)
        self._background.add(task)
        task.add_done_callback(self._background.discard)

    # -- commands -------------------------------------------------------------------------------
    async def set_mode(self, mode: FlightMode) -> None:
        """Switch the autopilot's flight mode and wait until its heartbeat shows it."""
        self._require_link()
        want = custom_mode_for(self.autopilot, mode)
        beat = self.link.latest.get("HEARTBEAT")
        if beat is not None and beat.custom_mode == want:
            return
        p1, p2, p3 = set_mode_params(self.autopilot, mode)
        await self.commands.long(mav.MAV_CMD_DO_SET_MODE, p1, p2, p3, label=f"mode {mode.value}")
        await self.link.wait_for("HEARTBEAT", lambda m: m.custom_mode == want, 2.0)

    async def arm(self) -> None:
        state = self.state()
        if state.armed:
            raise FcError(f"{self._name()}: already armed")
        if self.autopilot is not Autopilot.PX4:
            await self.set_mode(FlightMode.GUIDED)
        self._arming = True
        asked_at = monotonic()
        try:
            await self.commands.long(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1, 0, label="arm")
            if not await self._until(lambda: self.state().armed, timeout_s=15.0):
                reason = self.link.reason_since(asked_at) or self.link.describe()
                raise FcError(f"{self._name()}: arming was interrupted ({reason})")
        finally:
            self._arming = False

    async def disarm(self, *, force: bool = False) -> None:
        if not self.state().armed:
            return
        magic = FORCE_DISARM_MAGIC if force else 0
        await self.commands.long(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, magic, label="disarm")
        await self.link.wait_for("HEARTBEAT", lambda m: not is_armed(m), 2.0)

    async def takeoff(self, altitude_m: float) -> None:
        """Climb to ``altitude_m`` above home; in the air, change altitude where it is."""
        self._refuse_unless_armed()
        self._check_altitude(altitude_m)
        if self.state().in_air:
            here = self.position()
            await self.goto(LLA(here.lat, here.lon, self.home().alt_m + altitude_m))
            return
        await self._takeoff_command(altitude_m)

    def _recently_took_off(self) -> bool:
        at = getattr(self, "_takeoff_at", None)
        return at is not None and self.clock.now() - at < 10.0

    async def _takeoff_command(self, altitude_m: float) -> None:
        if self.autopilot is Autopilot.PX4:  # PX4: AMSL altitude, switches to AUTO.TAKEOFF itself
            nan = math.nan
            amsl = self.home().alt_m + altitude_m
            await self.commands.long(mav.MAV_CMD_NAV_TAKEOFF, -1, 0, 0, nan, nan, nan, amsl)
            self._takeoff_at = self.clock.now()
            return
        await self.set_mode(FlightMode.GUIDED)
        await self.commands.long(mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, altitude_m)
        self._takeoff_at = self.clock.now()

    async def goto(self, target: LLA) -> None:
        home = self.home()
        if target.alt_m < home.alt_m:
            raise FcError(
                f"{self._name()}: target altitude {target.alt_m:.1f} m AMSL is below"
                f" home ({home.alt_m:.1f} m AMSL)"
            )
        self._refuse_unless_armed()
        relative = target.alt_m - home.alt_m
        self._check_altitude(relative)
        lat, lon = round(target.lat * 1e7), round(target.lon * 1e7)
        if self.autopilot is Autopilot.PX4:
            flags = mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE
            await self.commands.int_(
                mav.MAV_CMD_DO_REPOSITION,
                (-1, flags, 0, math.nan),
                x=lat,
                y=lon,
                z=target.alt_m,
                frame=mav.MAV_FRAME_GLOBAL_INT,
            )
            return
        if not self.state().in_air and not self._recently_took_off():
            # Copter ignores targets on the ground: take off first. The in-air state lags the
            # takeoff by a heartbeat, so a refusal because it is already flying is not an error.
            try:
                await self._takeoff_command(relative)
            except FcError as exc:
                if "already flying" not in str(exc).lower():
                    raise
        await self.set_mode(FlightMode.GUIDED)
        await self._send_target(lat, lon, relative)

    async def _send_target(self, lat: int, lon: int, relative_alt_m: float) -> None:
        message = mav.MAVLink_set_position_target_global_int_message(
            0, self.link.target_system, self.link.target_component,
            mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, _POSITION_ONLY,
            lat, lon, relative_alt_m, 0, 0, 0, 0, 0, 0, 0, 0,
        )  # fmt: skip
        for _ in range(3):  # no ACK for targets: ArduPilot echoes POSITION_TARGET_GLOBAL_INT
            sent_at = monotonic()
            try:
                self.link.send(message)
            except LinkLost as exc:
                raise FcError(str(exc)) from exc
            echo = await self.link.wait_for(
                "POSITION_TARGET_GLOBAL_INT",
                lambda m: abs(m.lat_int - lat) <= 1 and abs(m.lon_int - lon) <= 1,
                0.6,  # wall seconds: the echo streams at 4 Hz of vehicle time
            )
            if echo is not None:
                return
            reason = self.link.reason_since(sent_at)
            if reason:
                raise FcError(f"{self._name()}: position target refused: {reason}")

    async def set_param(self, name: str, value: float) -> None:
        """Set an autopilot parameter, confirmed by its echo (the fence's FENCE_* on upload)."""
        self._require_link()
        await session.set_param(self.link, name, value)

    def flight_params(self) -> dict[str, float]:
        """How this vehicle flies, from its parameters (SI units; for the planner)."""
        return {k: v for k, v in self.params.items() if k != "camera_type" and v > 0}

    async def hold(self) -> None:
        if not self.state().in_air:
            return
        await self.set_mode(FlightMode.HOLD)

    async def land(self) -> None:
        if not self.state().in_air:  # already down: just make it safe, like the sim backend
            await self.disarm()
            return
        await self.set_mode(FlightMode.LAND)

    async def return_to_launch(self) -> None:
        await self.set_mode(FlightMode.RTL)

    def takeover_cause(self) -> str | None:
        """The autopilot's own reason for a mode change it made (drone/takeover.py): a
        failsafe it announced in the last :data:`FAILSAFE_TEXT_S` wall seconds."""
        return self.link.failsafe_since(monotonic() - FAILSAFE_TEXT_S)

    async def reboot(self, *, force: bool = False) -> None:
        """Restart the autopilot; returns once it talks again. Refused in the air unless
        ``force``."""
        if self.state().in_air and not force:
            raise FcError(f"{self._name()}: refusing to reboot in the air; land first")
        boots = self._clock.boot_count
        magic = FORCE_REBOOT_MAGIC if force else 0
        self.rebooting = True
        self._clock.expect_reboot()
        try:
            await self.commands.long(
                mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1, 0, 0, 0, 0, magic, label="reboot"
            )
            loop = asyncio.get_running_loop()
            deadline = loop.time() + 30.0
            while self._clock.boot_count == boots and loop.time() < deadline:
                await asyncio.sleep(0.02)
            if self._clock.boot_count == boots:
                raise FcError(f"{self._name()}: did not come back from the reboot in 30 s")
            await self.link.wait_for("HEARTBEAT", timeout_s=5.0)
        finally:
            self.rebooting = False
        await self.request_streams()

    async def rebuild_telemetry(self) -> None:
        """Ask for every stream again (after a reboot, or a ground station changed them)."""
        await self.request_streams()

    async def request_object(self, name: str) -> dict[str, Any]:
        """A UAVObject view (``GPSPosition``, …) or the latest MAVLink message of that type."""
        return await objects.request_object(self, name)

    # -- helpers --------------------------------------------------------------------------------
    def _require_link(self) -> None:
        if not self.link.link_ok:
            raise FcError(f"{self._name()} is not connected ({self.link.describe()})")

    def _refuse_unless_armed(self) -> None:
        self._require_link()
        if not self.state().armed:
            if self._arming:
                raise FcError(f"{self._name()}: still arming")
            raise FcError(f"{self._name()}: not armed; arm it first")

    def _check_altitude(self, altitude_m: float) -> None:
        if not altitude_m >= MIN_TARGET_ALT_M:
            raise FcError(
                f"{self._name()}: target altitude {altitude_m:.1f} m above home is below the"
                f" {MIN_TARGET_ALT_M} m minimum; use land() to go down"
            )

    async def _until(self, predicate, *, timeout_s: float) -> bool:
        """Wait on the vehicle clock (polling at 20 Hz of vehicle time) for ``predicate``."""
        deadline = self._clock.now() + timeout_s
        while not predicate():
            if self._clock.now() >= deadline or not self.link.link_ok:
                return predicate()
            await self._clock.sleep(0.05)
        return True
