"""Setting up a MAVLink session with an autopilot: the message rates we want, home, and the
parameters the backend reads (Flight Controller Interface, seed 4.1.2.1).

Rates are asked for with MAV_CMD_SET_MESSAGE_INTERVAL (one command per message, each
acknowledged); an autopilot that knows none of them gets the legacy REQUEST_DATA_STREAM. Home is
requested with MAV_CMD_REQUEST_MESSAGE until HOME_POSITION arrives: without it there is no frame
for relative altitudes, so connecting fails with that reason.
"""

from __future__ import annotations

import asyncio
import logging

from dronefleet.drone.fc.mavlink.commands import CommandSender
from dronefleet.drone.fc.mavlink.link import MavlinkLink
from dronefleet.protocols.mavlink.codec import Message, message_id, text_field
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.vehicle.base import FcError

log = logging.getLogger(__name__)

#: Wall seconds without a further PARAM_VALUE that end a burst of parameter answers.
_PARAM_QUIET_S = 0.2
#: Names asked at once: ArduPilot queues 20 PARAM_REQUEST_READs per link and drops the rest
#: unanswered (GCS_MAVLINK::param_requests), so the flight figures, 40 names, are asked in
#: batches (WP_SPD, sorted last, went unanswered once the way-home names were added).
_PARAM_BATCH = 15
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


async def set_param(
    link: MavlinkLink, name: str, value: float, *, timeout_s: float = 1.0, retries: int = 3
) -> None:
    """Set a parameter (PARAM_SET) and wait until the autopilot's PARAM_VALUE echoes the new
    value, as ground stations confirm it; :class:`FcError` if it never does."""
    message = mav.MAVLink_param_set_message(
        link.target_system, link.target_component, name.encode(), float(value),
        mav.MAV_PARAM_TYPE_REAL32,
    )  # fmt: skip

    def echo(m: Message) -> bool:
        return text_field(m.param_id) == name and abs(float(m.param_value) - value) < 1e-3

    for _ in range(retries):
        link.send(message)
        if await link.wait_for("PARAM_VALUE", echo, timeout_s) is not None:
            return
    raise FcError(f"the autopilot did not take {name} = {value:g} ({link.describe()})")


async def read_params(
    link: MavlinkLink,
    wanted: tuple[tuple[str, tuple[tuple[str, float], ...]], ...],
    timeout_s: float = 1.0,
) -> dict[str, float]:
    """For each ``(key, ((name, factor), ...))``: the first of the names the autopilot answers
    for, times its factor. The names are asked ``_PARAM_BATCH`` at once and each batch's answers
    gathered for up to ``timeout_s`` (an autopilot stays silent about a name it does not know,
    so asking one by one would cost a timeout per unknown name)."""
    names = {name for _, candidates in wanted for name, _ in candidates}
    answers: dict[str, float] = {}
    heard = asyncio.Event()

    def collect(msg: Message) -> None:
        if msg.get_type() == "PARAM_VALUE":
            name = text_field(msg.param_id)
            if name in names:
                answers[name] = float(msg.param_value)
                heard.set()

    remove = link.add_listener(collect)
    try:
        ordered = sorted(names)
        for start in range(0, len(ordered), _PARAM_BATCH):
            batch = ordered[start : start + _PARAM_BATCH]
            await _ask(link, batch, answers, heard, timeout_s)
    finally:
        remove()
    values: dict[str, float] = {}
    for key, candidates in wanted:
        for name, factor in candidates:
            if name in answers:
                values[key] = answers[name] * factor
                break
    return values


async def _ask(
    link: MavlinkLink,
    batch: list[str],
    answers: dict[str, float],
    heard: asyncio.Event,
    timeout_s: float,
) -> None:
    """Ask for ``batch`` and gather the answers into ``answers``: they come as one burst, so
    wait for the first (``timeout_s`` at most), then until a short quiet gap."""
    for name in batch:
        link.send(
            mav.MAVLink_param_request_read_message(
                link.target_system, link.target_component, name.encode(), -1
            )
        )
    wait_s = timeout_s
    while any(name not in answers for name in batch):
        heard.clear()
        try:
            async with asyncio.timeout(wait_s):
                await heard.wait()
        except TimeoutError:
            break
        wait_s = _PARAM_QUIET_S
