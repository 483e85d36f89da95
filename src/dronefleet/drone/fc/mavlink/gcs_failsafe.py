"""The autopilot's own link-loss failsafe (issue 26, item 3): an orphaned vehicle goes home.

The drone software is its autopilot's ground station: it sends the HEARTBEATs a ground station
sends (:mod:`.link`). If it dies — its process killed, its board browned out — the autopilot
flies on with the last target it was given. Measured on SITL: a drone process SIGKILLed left its
copter hovering in GUIDED until the battery read 0 %. Both autopilots can act by themselves when
their ground station falls silent:

- ArduPilot Copter (``ArduCopter/events.cpp``, ``failsafe_gcs_check``/``failsafe_gcs_on_event``):
  no HEARTBEAT from ``SYSID_MYGCS`` (255, ours) for ``FS_GCS_TIMEOUT`` seconds (5 by default,
  counted on the autopilot's own clock), once a ground station has been heard, triggers
  ``FS_GCS_ENABLE``'s action: 0 off (the default), 1 RTL, 2 RTL (was: continue in AUTO), 3
  SmartRTL or RTL, 4 SmartRTL or Land, 5 Land, 6 DO_LAND_START or RTL, 7 Brake or Land. Disarmed
  it only announces it; landed it disarms; a landing forced by the battery failsafe goes on, and
  so does any landing when ``FS_OPTIONS`` bit 3 (8, "continue if landing") is set; bit 1 (2)
  lets AUTO go on. It says "GCS Failsafe" in a STATUSTEXT, "GCS Failsafe Cleared" when heard.
- PX4 (docs.px4.io, Safety: Data Link Loss): no GCS heartbeat for ``COM_DL_LOSS_T`` seconds (10)
  triggers ``NAV_DLL_ACT``: 0 disabled (the default), 1 Hold, 2 Return, 3 Land, 5 Terminate, 6
  Disarm.

At connect the drone reads them (:func:`ensure`). Allowed to (``dronefleet drone
--set-autopilot-failsafe``, the default), it turns a disabled failsafe on — ArduPilot
``FS_GCS_ENABLE`` 1 (RTL) with ``FS_OPTIONS`` bit 3 (the drone's own battery landing goes on
without it), PX4 ``NAV_DLL_ACT`` 2 (Return) — and leaves an operator's own choice (any action
but off, and the timeout) as it is. Either way the result goes into every heartbeat
(``link_failsafe``) and the pre-flight checklist fails a drone whose autopilot has none. The
heartbeats that keep a live drone from tripping it come every second of the autopilot's clock
(:mod:`.link`).
"""

from __future__ import annotations

import logging
import struct
from dataclasses import dataclass

from dronefleet.drone.fc.mavlink.link import MavlinkLink
from dronefleet.protocols.mavlink.codec import Message, text_field
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.modes import Autopilot
from dronefleet.vehicle.base import FcError

log = logging.getLogger(__name__)

#: ArduPilot Copter's FS_GCS_ENABLE values.
ARDUPILOT_ACTIONS = {
    0: "off",
    1: "rtl",
    2: "rtl",
    3: "smartrtl_or_rtl",
    4: "smartrtl_or_land",
    5: "land",
    6: "land_start_or_rtl",
    7: "brake_or_land",
}
#: PX4's NAV_DLL_ACT values.
PX4_ACTIONS = {0: "off", 1: "hold", 2: "rtl", 3: "land", 5: "terminate", 6: "disarm"}
#: FS_OPTIONS bit 3: a landing goes on through a GCS failsafe (ArduCopter FailsafeOption).
CONTINUE_IF_LANDING = 8
#: What the drone sets a disabled failsafe to: RTL.
ARDUPILOT_RTL, PX4_RETURN = 1, 2
_INTS = (mav.MAV_PARAM_TYPE_INT8, mav.MAV_PARAM_TYPE_INT16, mav.MAV_PARAM_TYPE_INT32)


@dataclass(frozen=True)
class LinkFailsafe:
    """What the autopilot does by itself when the drone software falls silent."""

    action: str  # "off", "rtl", "land", ...; "unknown" when it would not say
    timeout_s: float | None = None
    set_by_drone: bool = False  # this drone turned it on at connect

    @property
    def off(self) -> bool:
        return self.action == "off"

    def describe(self) -> str:
        if self.action == "unknown":
            return "the autopilot did not say what it does when the drone software falls silent"
        if self.off:
            return (
                "the autopilot's link-loss failsafe is off: a vehicle whose drone software dies"
                " flies on (hovers) until its battery is flat"
            )
        after = f" after {self.timeout_s:g} s" if self.timeout_s is not None else ""
        who = " (set by the drone)" if self.set_by_drone else ""
        return f"the autopilot's link-loss failsafe: {self.action}{after} without the drone{who}"


def _names(autopilot: Autopilot) -> tuple[str, str, dict[int, str], int] | None:
    if autopilot is Autopilot.ARDUPILOT:
        return "FS_GCS_ENABLE", "FS_GCS_TIMEOUT", ARDUPILOT_ACTIONS, ARDUPILOT_RTL
    if autopilot is Autopilot.PX4:
        return "NAV_DLL_ACT", "COM_DL_LOSS_T", PX4_ACTIONS, PX4_RETURN
    return None


def _value(msg: Message, autopilot: Autopilot) -> float:
    """A PARAM_VALUE's value: PX4 sends integers byte-wise in the float field."""
    if autopilot is Autopilot.PX4 and msg.param_type in _INTS:
        return float(struct.unpack("<i", struct.pack("<f", msg.param_value))[0])
    return float(msg.param_value)


async def _read(
    link: MavlinkLink, name: str, autopilot: Autopilot, timeout_s: float = 1.0
) -> Message | None:
    for _ in range(2):
        link.send(
            mav.MAVLink_param_request_read_message(
                link.target_system, link.target_component, name.encode(), -1
            )
        )
        msg = await link.wait_for(
            "PARAM_VALUE", lambda m: text_field(m.param_id) == name, timeout_s
        )
        if msg is not None:
            return msg
    return None


async def _write(
    link: MavlinkLink, name: str, value: int, autopilot: Autopilot, *, timeout_s: float = 1.0
) -> None:
    """Set an integer parameter, confirmed by its echo (PX4: byte-wise, as it reads them)."""
    if autopilot is Autopilot.PX4:
        raw, kind = struct.unpack("<f", struct.pack("<i", value))[0], mav.MAV_PARAM_TYPE_INT32
    else:
        raw, kind = float(value), mav.MAV_PARAM_TYPE_REAL32
    message = mav.MAVLink_param_set_message(
        link.target_system, link.target_component, name.encode(), raw, kind
    )
    for _ in range(3):
        link.send(message)
        echo = await link.wait_for(
            "PARAM_VALUE",
            lambda m: text_field(m.param_id) == name and _value(m, autopilot) == value,
            timeout_s,
        )
        if echo is not None:
            return
    raise FcError(f"the autopilot did not take {name} = {value} ({link.describe()})")


async def ensure(link: MavlinkLink, autopilot: Autopilot, *, set_it: bool) -> LinkFailsafe:
    """Read the autopilot's link-loss failsafe and, with ``set_it``, turn it on (RTL) when off
    (see the module doc). Never raises for a parameter the autopilot will not read or take: the
    result says so."""
    names = _names(autopilot)
    if names is None:
        return LinkFailsafe("unknown")
    enable_name, timeout_name, actions, rtl = names
    enable = await _read(link, enable_name, autopilot)
    timeout = await _read(link, timeout_name, autopilot)
    timeout_s = _value(timeout, autopilot) if timeout is not None else None
    if enable is None:
        log.warning("autopilot at %s: %s not read; its link-loss failsafe is unknown", link.url,
                    enable_name)  # fmt: skip
        return LinkFailsafe("unknown", timeout_s)
    value = int(_value(enable, autopilot))
    state = LinkFailsafe(actions.get(value, f"{enable_name}={value}"), timeout_s)
    if state.off and set_it:
        try:
            await _write(link, enable_name, rtl, autopilot)
            if autopilot is Autopilot.ARDUPILOT:
                options = await _read(link, "FS_OPTIONS", autopilot)
                if options is not None:
                    bits = int(_value(options, autopilot))
                    if not bits & CONTINUE_IF_LANDING:
                        await _write(link, "FS_OPTIONS", bits | CONTINUE_IF_LANDING, autopilot)
            state = LinkFailsafe(actions[rtl], timeout_s, set_by_drone=True)
        except FcError as exc:
            log.warning("autopilot at %s: could not turn its link-loss failsafe on: %s",
                        link.url, exc)  # fmt: skip
    level = logging.WARNING if state.off else logging.INFO
    log.log(level, "autopilot at %s: %s", link.url, state.describe())
    return state
