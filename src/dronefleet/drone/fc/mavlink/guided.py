"""Flying to a point with the ``mavlink`` backend: take-off, position targets and holding where
it is (mixed into the controller).

ArduPilot Copter flies them in GUIDED: MAV_CMD_NAV_TAKEOFF (altitude above home), then
SET_POSITION_TARGET_GLOBAL_INT targets, confirmed by their POSITION_TARGET_GLOBAL_INT echo (no
ACK). PX4 has no GUIDED (OFFBOARD needs a setpoint stream): its NAV_TAKEOFF takes an altitude
above mean sea level and switches to AUTO.TAKEOFF itself, and targets go as MAV_CMD_DO_REPOSITION
in AUTO.LOITER, which :class:`.mode_watch.ModeWatch` tells apart from someone's hold.
"""

from __future__ import annotations

import math

from dronefleet.clock import monotonic
from dronefleet.drone.fc.mavlink.link import LinkLost
from dronefleet.drone.fc.mavlink.mode_watch import ModeWatch
from dronefleet.geo.types import LLA
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.modes import Autopilot, Px4Auto, Px4Main, px4_custom_mode
from dronefleet.vehicle.base import FcError, FlightMode

#: The lowest target above home (m); to go lower is to land (:meth:`land`).
MIN_TARGET_ALT_M = 0.5
_POSITION_ONLY = 0b0000_1101_1111_1000  # SET_POSITION_TARGET type_mask: use lat/lon/alt only


class GuidedFlight(ModeWatch):
    """Take-off, targets and hold over ``self.link`` (mixed into the controller)."""

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
        return at is not None and self._clock.now() - at < 10.0

    async def _takeoff_command(self, altitude_m: float) -> None:
        if self.autopilot is Autopilot.PX4:  # PX4: AMSL altitude, switches to AUTO.TAKEOFF itself
            nan = math.nan
            amsl = self.home().alt_m + altitude_m
            # PX4 ACKs first and shows AUTO.TAKEOFF in a later HEARTBEAT: expected till then.
            self._expect(FlightMode.GUIDED, px4_custom_mode(Px4Main.AUTO, Px4Auto.TAKEOFF))
            self._loiter_ours = True  # the AUTO.LOITER this take-off ends in is ours
            try:
                await self.commands.long(mav.MAV_CMD_NAV_TAKEOFF, -1, 0, 0, nan, nan, nan, amsl)
            except BaseException:
                self._expected = None
                raise
            self._takeoff_at = self._clock.now()
            return
        await self.set_mode(FlightMode.GUIDED)
        await self.commands.long(mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, altitude_m)
        self._takeoff_at = self._clock.now()

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
            await self._reposition(lat, lon, target.alt_m, ours=True)
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

    async def _reposition(self, lat: int, lon: int, alt_amsl_m: float, *, ours: bool) -> None:
        """PX4: fly to a point in AUTO.LOITER (MAV_CMD_DO_REPOSITION, CHANGE_MODE flag). With
        ``ours`` the loiter is a target being flown (GUIDED), else a hold (HOLD)."""
        loiter = px4_custom_mode(Px4Main.AUTO, Px4Auto.LOITER)
        self._expect(FlightMode.GUIDED if ours else FlightMode.HOLD, loiter)
        try:
            await self.commands.int_(
                mav.MAV_CMD_DO_REPOSITION,
                (-1, mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, math.nan),
                x=lat,
                y=lon,
                z=alt_amsl_m,
                frame=mav.MAV_FRAME_GLOBAL_INT,
            )
        except BaseException:
            self._expected = None
            raise
        self._loiter_ours = ours

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

    async def hold(self) -> None:
        if not self.state().in_air:
            return
        beat = self.link.latest.get("HEARTBEAT")
        loiter = px4_custom_mode(Px4Main.AUTO, Px4Auto.LOITER)
        if self.autopilot is Autopilot.PX4 and beat is not None and beat.custom_mode == loiter:
            # Already in AUTO.LOITER, flying our DO_REPOSITION: PX4 ignores AUTO.LOITER asked
            # again (measured on SITL: it flew on to the target at 4 m/s), so hold here instead.
            here = self.position()
            await self._reposition(
                round(here.lat * 1e7), round(here.lon * 1e7), here.alt_m, ours=False
            )
            return
        await self.set_mode(FlightMode.HOLD)

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
