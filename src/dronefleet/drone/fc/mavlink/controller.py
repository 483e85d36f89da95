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

The controller is built of mixins, one concept each: :class:`.state.VehicleView` (the state
getters), :class:`.mode_watch.ModeWatch` (mode changes, and the mode seen) and
:class:`.guided.GuidedFlight` (take-off, targets, hold); what it reads on connect is in
:mod:`.session` and :mod:`.flight_params`.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

from dronefleet.clock import monotonic
from dronefleet.drone.fc.clock import AutopilotClock
from dronefleet.drone.fc.mavlink import gcs_failsafe, objects, payload, session
from dronefleet.drone.fc.mavlink.commands import CommandSender, Refused
from dronefleet.drone.fc.mavlink.flight_params import FLIGHT_PARAMS, flight_figures
from dronefleet.drone.fc.mavlink.gcs_failsafe import LinkFailsafe
from dronefleet.drone.fc.mavlink.guided import GuidedFlight
from dronefleet.drone.fc.mavlink.link import MavlinkLink
from dronefleet.drone.fc.mavlink.mission import MissionClient
from dronefleet.drone.fc.mavlink.session import DEFAULT_STREAMS_HZ
from dronefleet.drone.fc.mavlink.state import is_armed
from dronefleet.geo.types import LLA
from dronefleet.protocols.mavlink.codec import Message, text_field
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.modes import Autopilot
from dronefleet.vehicle.base import FcError, FlightMode

log = logging.getLogger(__name__)

#: ArduPilot's "really" values: disarm in flight, reboot while armed.
FORCE_DISARM_MAGIC = 21196
FORCE_REBOOT_MAGIC = 20190226
#: A refused ARM is asked again this many times in all, this many vehicle seconds apart.
ARM_TRIES = 3
ARM_RETRY_S = 1.0
#: The refusals asked again: the check failed now (ArduPilot answers FAILED for its arming
#: checks), or the autopilot says to try later. DENIED and UNSUPPORTED are final.
_RETRIED = {mav.MAV_RESULT_FAILED, mav.MAV_RESULT_TEMPORARILY_REJECTED}


class MavlinkFlightController(GuidedFlight):
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
        set_link_failsafe: bool = True,
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
        # Our heartbeats come every second of the autopilot's time, not the wall's (issue 26).
        self.link.vehicle_rate = lambda: self._clock.speedup
        #: Whether to turn the autopilot's link-loss failsafe on at connect when it is off.
        self.set_link_failsafe = set_link_failsafe
        #: What the autopilot does by itself if this drone's software dies (read at connect).
        self.link_failsafe: LinkFailsafe | None = None
        self.autopilot = Autopilot.GENERIC
        # What ModeWatch keeps of the modes we commanded and saw (mode_watch.py).
        self._expected = None
        self._loiter_ours = False
        self._mission_rtl = False
        self._seen_mode = None
        self.mission = MissionClient(self.link, self.commands, self.autopilot, self._clock)
        self.mission.on_start = lambda: self._expect(FlightMode.MISSION)
        self.mission.here = self._here
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
            self.link_failsafe = await gcs_failsafe.ensure(
                self.link, self.autopilot, set_it=self.set_link_failsafe
            )
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
        if kind == "HEARTBEAT" and msg.type != mav.MAV_TYPE_GCS:
            self._on_mode(msg.custom_mode)
        elif kind == "NAMED_VALUE_FLOAT":
            self.named_values[text_field(msg.name)] = (msg.value, self._clock.now())
        elif kind == "CAMERA_IMAGE_CAPTURED":
            self.captures.append(payload.capture_record(msg))

    def _here(self) -> LLA | None:
        """Where the vehicle is (home before the first position), None when neither is known."""
        try:
            return self.position()
        except FcError:
            return None

    def _on_link_change(self, ok: bool) -> None:
        if ok and self._connected and not self._closed:
            # The autopilot may have rebooted or forgotten our rates while we were apart.
            self._spawn(self.request_streams())

    def _spawn(self, coro) -> None:
        task = asyncio.get_running_loop().create_task(coro)
        self._background.add(task)
        task.add_done_callback(self._background.discard)

    # -- commands -------------------------------------------------------------------------------
    async def arm(self) -> None:
        state = self.state()
        if state.armed:
            raise FcError(f"{self._name()}: already armed")
        if self.autopilot is not Autopilot.PX4:
            await self.set_mode(FlightMode.GUIDED)
        self._arming = True
        asked_at = monotonic()
        try:
            await self._ask_to_arm()
            if not await self._until(lambda: self.state().armed, timeout_s=15.0):
                reason = self.link.reason_since(asked_at) or self.link.describe()
                raise FcError(f"{self._name()}: arming was interrupted ({reason})")
        finally:
            self._arming = False

    async def _ask_to_arm(self) -> None:
        """ARM, asked again while the autopilot refuses it as a pilot would retry, up to
        :data:`ARM_TRIES` times :data:`ARM_RETRY_S` vehicle seconds apart: some arming checks
        fail for a moment after boot (ArduPilot's "Arm: Logging not started" on a loaded host,
        until its log backend has started). A refusal that outlasts the tries is the error,
        with the autopilot's last reason."""
        for attempt in range(ARM_TRIES):
            try:
                await self.commands.long(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1, 0, label="arm")
                return
            except Refused as exc:
                if attempt + 1 == ARM_TRIES or exc.result not in _RETRIED:
                    raise
                log.info("%s: %s; asking again", self._name(), exc)
                await self._clock.sleep(ARM_RETRY_S)

    async def disarm(self, *, force: bool = False) -> None:
        if not self.state().armed:
            return
        magic = FORCE_DISARM_MAGIC if force else 0
        await self.commands.long(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, magic, label="disarm")
        await self.link.wait_for("HEARTBEAT", lambda m: not is_armed(m), 2.0)

    async def set_param(self, name: str, value: float) -> None:
        """Set an autopilot parameter, confirmed by its echo (the fence's FENCE_* on upload)."""
        self._require_link()
        await session.set_param(self.link, name, value)

    def flight_params(self) -> dict[str, float]:
        """How this vehicle flies, from its parameters (SI units; for the planner)."""
        return flight_figures(self.params)

    async def land(self) -> None:
        if not self.state().in_air:  # already down: just make it safe, like the sim backend
            await self.disarm()
            return
        await self.set_mode(FlightMode.LAND)

    async def return_to_launch(self) -> None:
        await self.set_mode(FlightMode.RTL)

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
    async def _until(self, predicate, *, timeout_s: float) -> bool:
        """Wait on the vehicle clock (polling at 20 Hz of vehicle time) for ``predicate``."""
        deadline = self._clock.now() + timeout_s
        while not predicate():
            if self._clock.now() >= deadline or not self.link.link_ok:
                return predicate()
            await self._clock.sleep(0.05)
        return True
