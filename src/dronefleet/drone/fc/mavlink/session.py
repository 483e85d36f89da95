"""Setting up a MAVLink session with an autopilot: the message rates we want, home, and the
parameters the backend reads (Flight Controller Interface, seed 4.1.2.1).

Rates are asked for with MAV_CMD_SET_MESSAGE_INTERVAL (one command per message, each
acknowledged); an autopilot that knows none of them gets the legacy REQUEST_DATA_STREAM. Home is
requested with MAV_CMD_REQUEST_MESSAGE until HOME_POSITION arrives: without it there is no frame
for relative altitudes, so connecting fails with that reason.
"""

from __future__ import annotations

import logging

from dronefleet.drone.fc.base import FcError
from dronefleet.drone.fc.mavlink.codec import dialect as mav
from dronefleet.drone.fc.mavlink.codec import message_id, text_field
from dronefleet.drone.fc.mavlink.commands import CommandSender
from dronefleet.drone.fc.mavlink.link import MavlinkLink

log = logging.getLogger(__name__)


async def request_streams(commands: CommandSender, streams_hz: dict[str, float]) -> None:
    """Set each message's rate (Hz of vehicle time; 0 or less stops it)."""
    link = commands.link
    failures = 0
    for name, hz in streams_hz.items():
        interval_us = 1e6 / hz if hz > 0 else -1
        try:
            await commands.long(mav.MAV_CMD_SET_MESSAGE_INTERVAL, message_id(name), interval_us)
        except FcError as exc:
            failures += 1
            log.debug("stream %s: %s", name, exc)
    if streams_hz and failures == len(streams_hz):
        log.warning("%s ignores SET_MESSAGE_INTERVAL; using REQUEST_DATA_STREAM", link.url)
        link.send(
            mav.MAVLink_request_data_stream_message(
                link.target_system, link.target_component, mav.MAV_DATA_STREAM_ALL, 10, 1
            )
        )


async def learn_home(commands: CommandSender, tries: int = 5) -> None:
    """Make sure HOME_POSITION (and a first GLOBAL_POSITION_INT) has arrived."""
    link = commands.link
    for _ in range(tries):
        if "HOME_POSITION" in link.latest:
            break
        try:
            await commands.long(mav.MAV_CMD_REQUEST_MESSAGE, message_id("HOME_POSITION"))
        except FcError as exc:
            log.debug("home request: %s", exc)
        await link.wait_for("HOME_POSITION", timeout_s=1.0)
    if "HOME_POSITION" not in link.latest:
        raise FcError(f"the autopilot at {link.url} has no home position (no GPS fix yet?)")
    if "GLOBAL_POSITION_INT" not in link.latest:
        await link.wait_for("GLOBAL_POSITION_INT", timeout_s=5.0)


async def read_param(link: MavlinkLink, name: str, timeout_s: float = 1.0) -> float | None:
    """One parameter's value (PARAM_REQUEST_READ), or None when the autopilot does not answer."""
    link.send(
        mav.MAVLink_param_request_read_message(
            link.target_system, link.target_component, name.encode(), -1
        )
    )
    answer = await link.wait_for("PARAM_VALUE", lambda m: text_field(m.param_id) == name, timeout_s)
    return None if answer is None else float(answer.param_value)


async def read_params(
    link: MavlinkLink, names: tuple[str, ...], timeout_s: float = 0.5
) -> dict[str, float]:
    """The parameters among ``names`` that the autopilot answers for (PX4 lacks ArduPilot's)."""
    values = {}
    for name in names:
        value = await read_param(link, name, timeout_s)
        if value is not None:
            values[name] = value
    return values
