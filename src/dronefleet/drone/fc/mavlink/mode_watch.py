"""The flight mode as the ``mavlink`` backend commands and tells it (mixed into the controller).

Modes are switched with MAV_CMD_DO_SET_MODE and confirmed by the HEARTBEAT. A mode this drone
commanded is *expected* until the HEARTBEAT shows it, so drone/takeover.py does not take the mode
before it for someone else's; a mode change the autopilot made itself is explained by the
failsafe it announced (:meth:`ModeWatch.takeover_cause`). On PX4 one mode means two things
(protocols/mavlink/modes.py): AUTO.LOITER is a target this drone flies (GUIDED) or someone's hold
(HOLD), and AUTO.RTL the mission's own return item (MISSION) or a return (RTL); which one is
learned from the mode before it and what this drone asked for.
"""

from __future__ import annotations

from dronefleet.clock import monotonic
from dronefleet.drone.fc.mavlink.commands import CommandSender
from dronefleet.drone.fc.mavlink.mission import MissionClient
from dronefleet.drone.fc.mavlink.state import VehicleView
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.modes import (
    Autopilot,
    Px4Auto,
    Px4Main,
    custom_mode_for,
    decode_mode,
    px4_custom_mode,
    set_mode_params,
)
from dronefleet.vehicle.base import FcError, FlightMode

#: How recent (wall seconds) a failsafe STATUSTEXT must be to explain a mode change.
FAILSAFE_TEXT_S = 3.0
#: Wall seconds a mode this drone commanded is waited for in the HEARTBEAT before the mode there
#: is taken as it is (drone/takeover.py, :meth:`ModeWatch.expected_mode`). PX4
#: ACKs NAV_TAKEOFF and DO_REPOSITION before its next HEARTBEAT shows AUTO.TAKEOFF/AUTO.LOITER
#: (measured on SITL: about 0.1 s later; its heartbeat is 1 Hz at worst).
EXPECT_MODE_S = 3.0


class ModeWatch(VehicleView):
    """Mode switching and the mode seen, over ``self.link`` (mixed into the controller)."""

    commands: CommandSender
    mission: MissionClient
    # The mode we commanded and not seen yet (custom_mode, wall deadline), and on PX4 whether
    # the AUTO.LOITER it is in flies our target (DO_REPOSITION, or the hover our take-off
    # ends in) rather than a hold someone chose (modes.py: both are AUTO.LOITER).
    _expected: tuple[int, FlightMode, float] | None
    _loiter_ours: bool
    _mission_rtl: bool
    _seen_mode: int | None

    async def set_mode(self, mode: FlightMode) -> None:
        """Switch the autopilot's flight mode and wait until its heartbeat shows it."""
        self._require_link()
        want = custom_mode_for(self.autopilot, mode)
        beat = self.link.latest.get("HEARTBEAT")
        if beat is not None and beat.custom_mode == want:
            return
        p1, p2, p3 = set_mode_params(self.autopilot, mode)
        self._expect(mode, want)
        try:
            await self.commands.long(
                mav.MAV_CMD_DO_SET_MODE, p1, p2, p3, label=f"mode {mode.value}"
            )
        except BaseException:
            self._expected = None
            raise
        await self.link.wait_for("HEARTBEAT", lambda m: m.custom_mode == want, 2.0)

    def _expect(self, mode: FlightMode, custom_mode: int | None = None) -> None:
        """A mode this drone just commanded: until the HEARTBEAT shows it (or
        :data:`EXPECT_MODE_S`), the mode there is the one before it, not someone else's."""
        custom = custom_mode_for(self.autopilot, mode) if custom_mode is None else custom_mode
        self._expected = (custom, mode, monotonic() + EXPECT_MODE_S)

    def expected_mode(self) -> FlightMode | None:
        """The mode this drone commanded and the HEARTBEAT does not show yet, or None
        (drone/takeover.py counts it as chosen and sees no takeover meanwhile)."""
        if self._expected is None:
            return None
        custom_mode, mode, deadline = self._expected
        beat = self.link.latest.get("HEARTBEAT")
        if (beat is not None and beat.custom_mode == custom_mode) or monotonic() > deadline:
            self._expected = None
            return None
        return mode

    def takeover_cause(self) -> str | None:
        """The autopilot's own reason for a mode change it made (drone/takeover.py): a
        failsafe it announced in the last :data:`FAILSAFE_TEXT_S` wall seconds."""
        return self.link.failsafe_since(monotonic() - FAILSAFE_TEXT_S)

    def _on_mode(self, custom_mode: int) -> None:
        """PX4: whose the AUTO.LOITER is. Entered right after our own AUTO.TAKEOFF (PX4's
        take-off ends hovering in AUTO.LOITER by itself, docs.px4.io Takeoff Mode: "ascends ...
        and holds position") or while our DO_REPOSITION is expected: ours, a target being flown
        (GUIDED). Entered from any other mode: someone's hold (HOLD)."""
        before, self._seen_mode = self._seen_mode, custom_mode
        if self.autopilot is not Autopilot.PX4 or custom_mode == before:
            return
        loiter = px4_custom_mode(Px4Main.AUTO, Px4Auto.LOITER)
        takeoff = px4_custom_mode(Px4Main.AUTO, Px4Auto.TAKEOFF)
        rtl = px4_custom_mode(Px4Main.AUTO, Px4Auto.RTL)
        if custom_mode == rtl:
            # PX4 flies a mission's NAV_RETURN_TO_LAUNCH in AUTO.RTL (ArduPilot stays in AUTO):
            # that AUTO.RTL is the mission's own.
            mission = px4_custom_mode(Px4Main.AUTO, Px4Auto.MISSION)
            self._mission_rtl = before == mission and self.mission.flying_to_rtl()
        else:
            self._mission_rtl = False
        if custom_mode == loiter:
            expected = self._expected is not None and self._expected[:2] == (
                loiter,
                FlightMode.GUIDED,
            )
            self._loiter_ours = expected or (before == takeoff and self._loiter_ours)
        elif custom_mode != takeoff:
            self._loiter_ours = False

    def _decode(self, custom_mode: int) -> FlightMode:
        loiter = px4_custom_mode(Px4Main.AUTO, Px4Auto.LOITER)
        if self.autopilot is Autopilot.PX4 and custom_mode == loiter and self._loiter_ours:
            return FlightMode.GUIDED
        rtl = px4_custom_mode(Px4Main.AUTO, Px4Auto.RTL)
        if self.autopilot is Autopilot.PX4 and custom_mode == rtl and self._mission_rtl:
            return FlightMode.MISSION  # the mission's own RTL item (see _on_mode)
        return decode_mode(self.autopilot, custom_mode)

    def _require_link(self) -> None:
        if not self.link.link_ok:
            raise FcError(f"{self._name()} is not connected ({self.link.describe()})")
