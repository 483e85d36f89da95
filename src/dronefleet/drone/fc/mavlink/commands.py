"""Commands with acknowledgement: COMMAND_LONG / COMMAND_INT → COMMAND_ACK, with retries.

The MAVLink command protocol is fire-and-hope over a lossy radio: a command is resent (with its
``confirmation`` counter raised) until a COMMAND_ACK for it arrives. ``IN_PROGRESS`` acks extend
the wait. A refusal raises :class:`~dronefleet.vehicle.base.FcError` carrying the autopilot's
own reason — the STATUSTEXT it sent alongside the refusal (e.g. "Arm: battery too low") — so the
Drone Controller can pass it to the operator as the seed's controller did with dRonin's answers.
"""

from __future__ import annotations

import asyncio

from dronefleet.clock import monotonic
from dronefleet.drone.fc.mavlink.link import LinkLost, MavlinkLink
from dronefleet.protocols.mavlink.codec import Message, command_name, result_name
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.vehicle.base import FcError

#: How long a refusal waits for its STATUSTEXT when the ACK came first (wall seconds).
_REASON_GRACE_S = 0.15


class Refused(FcError):
    """The autopilot answered a command with a refusal: ``result`` is its MAV_RESULT."""

    def __init__(self, message: str, result: int) -> None:
        super().__init__(message)
        self.result = result


class CommandSender:
    """Sends commands to the link's autopilot and waits for their acknowledgement."""

    def __init__(self, link: MavlinkLink, *, ack_timeout_s: float = 1.0, retries: int = 3) -> None:
        self.link = link
        self.ack_timeout_s = ack_timeout_s
        self.retries = retries
        self._lock: dict[int, asyncio.Lock] = {}

    async def long(self, command: int, *params: float, label: str | None = None) -> Message:
        """COMMAND_LONG ``command`` with up to 7 params; returns the accepting COMMAND_ACK."""
        p = [float(x) for x in params] + [0.0] * (7 - len(params))

        def build(confirmation: int) -> Message:
            return mav.MAVLink_command_long_message(
                self._target(), self.link.target_component, command, confirmation, *p
            )

        return await self._run(command, build, label)

    async def int_(
        self,
        command: int,
        params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0),
        *,
        x: int = 0,
        y: int = 0,
        z: float = 0.0,
        frame: int = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        label: str | None = None,
    ) -> Message:
        """COMMAND_INT (positions as 1e7 degrees); same acknowledgement rules."""

        def build(_: int) -> Message:
            return mav.MAVLink_command_int_message(
                self._target(), self.link.target_component, frame, command, 0, 0, *params, x, y, z
            )

        return await self._run(command, build, label)

    def _target(self) -> int:
        if self.link.target_system is None:
            raise FcError(self.link.describe())
        return self.link.target_system

    async def _run(self, command: int, build, label: str | None) -> Message:
        name = label or command_name(command)
        lock = self._lock.setdefault(command, asyncio.Lock())
        async with lock:  # one outstanding command of a kind: acks carry no request id
            sent_at = monotonic()
            for attempt in range(self.retries + 1):
                try:
                    self.link.send(build(attempt))
                except LinkLost as exc:
                    raise FcError(f"{name}: {exc}") from exc
                ack = await self._await_ack(command)
                if ack is not None:
                    return await self._judge(ack, name, sent_at)
            raise FcError(
                f"{name}: no COMMAND_ACK after {self.retries + 1} tries ({self.link.describe()})"
            )

    async def _await_ack(self, command: int) -> Message | None:
        ack = await self.link.wait_for(
            "COMMAND_ACK", lambda m: m.command == command, self.ack_timeout_s
        )
        # IN_PROGRESS: the autopilot works on it; wait (longer) for the final answer.
        while ack is not None and ack.result == mav.MAV_RESULT_IN_PROGRESS:
            ack = await self.link.wait_for(
                "COMMAND_ACK", lambda m: m.command == command, 10 * self.ack_timeout_s
            )
        return ack

    async def _judge(self, ack: Message, name: str, sent_at: float) -> Message:
        if ack.result == mav.MAV_RESULT_ACCEPTED:
            return ack
        reason = self.link.reason_since(sent_at)
        if reason is None:
            await asyncio.sleep(_REASON_GRACE_S)
            reason = self.link.reason_since(sent_at)
        verdict = result_name(ack.result)
        raise Refused(f"{name} refused ({verdict})" + (f": {reason}" if reason else ""), ack.result)
