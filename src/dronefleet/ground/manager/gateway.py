"""The Drone Manager's side of the broker (seed 4.3.3, Fig. 4.34): HTTP calls become requests.

Before a command goes out, the Drone Identifier is asked over the broker whether the drone is known
(404 if not) and alive (409 with its last-seen if lost). The command then carries a fresh
``request_id`` to ``<id>/control/in`` (or ``<id>/mission/in``) and the HTTP answer is the drone's
answer echoing it, or 504 when none comes in time. Every command, whatever its outcome, goes to
the audit log with who sent it.
"""

from __future__ import annotations

import logging
import secrets
from typing import Any

from dronefleet.clock import timestamp_s
from dronefleet.ground.identifier import QUERY_TOPIC, DroneIdentifier, identifier_query
from dronefleet.ground.manager.auth import Principal
from dronefleet.ground.manager.errors import ApiError
from dronefleet.ground.state import StateStore
from dronefleet.messaging.client import BrokerClient, BrokerUnavailable
from dronefleet.messaging.gear import GearRequest
from dronefleet.messaging.missions import MissionRequest
from dronefleet.messaging.rpc import Requester, RequestTimeout
from dronefleet.messaging.topics import Channel, Direction, any_drone, check_drone_id, ground, topic

log = logging.getLogger(__name__)

IDENTIFIER_TIMEOUT_S = 3.0


class DroneGateway:
    def __init__(
        self,
        broker_url: Any,
        state: StateStore,
        *,
        client_id: str,
        timeout_s: float = 30.0,
        identifier: DroneIdentifier | None = None,
    ) -> None:
        #: The Drone Identifier of this process, read directly: the fleet is in memory here, and
        #: a request over the broker waited behind the telemetry backlog (issue 27: REST p99 of
        #: 1.2-4.9 s, then 504, at 1000 drones). Without one, it is asked over the broker.
        self.identifier = identifier
        self.client = BrokerClient(broker_url, client_id)
        self.requester = Requester(self.client)
        self.state = state
        self.timeout_s = timeout_s
        # Our own reply topic, like the seed's per-component exchange (Fig. 4.31-4.32).
        self.identifier_reply = ground("manager", secrets.token_hex(4), "identifier")

    async def start(self) -> DroneGateway:
        await self.client.start()
        return self

    async def stop(self) -> None:
        await self.client.stop()

    # -- Drone Identifier ----------------------------------------------------------------------
    async def ask_identifier(self, query: str, drone_id: str | None = None) -> dict[str, Any]:
        if self.identifier is not None:
            return self.identifier.answer(query, drone_id)
        message = {**identifier_query(query, drone_id), "reply_to": self.identifier_reply}
        try:
            return await self.requester.request(
                QUERY_TOPIC, self.identifier_reply, message, timeout_s=IDENTIFIER_TIMEOUT_S
            )
        except (RequestTimeout, BrokerUnavailable) as exc:
            raise ApiError(504, f"the Drone Identifier did not answer: {exc}") from exc

    async def fleet(self) -> list[dict[str, Any]]:
        return (await self.ask_identifier("discover")).get("drones") or []

    async def drone(self, drone_id: str) -> dict[str, Any]:
        """The Identifier's record of a drone; 422 for a malformed id, 404 for an unknown one."""
        try:
            check_drone_id(drone_id)
        except ValueError as exc:
            raise ApiError(422, str(exc)) from exc
        record = (await self.ask_identifier("drone", drone_id)).get("drone")
        if not record:
            raise ApiError(404, f"unknown drone {drone_id!r}: no heartbeat from it yet")
        return record

    async def online_drone(self, drone_id: str) -> dict[str, Any]:
        record = await self.drone(drone_id)
        if record.get("status") == "lost":
            ago = timestamp_s() - float(record.get("last_seen") or 0)
            raise ApiError(
                409,
                f"drone {drone_id} is not connected (last heartbeat {ago:.0f} s ago)",
                last_seen=record.get("last_seen"),
                status="lost",
            )
        return record

    # -- requests to a drone -------------------------------------------------------------------
    async def _request(
        self, drone_id: str, channel: Channel, message: dict[str, Any], timeout_s: float | None
    ) -> dict[str, Any]:
        timeout = timeout_s or self.timeout_s
        try:
            return await self.requester.request(
                topic(drone_id, channel, Direction.IN),
                any_drone(channel),
                message,
                timeout_s=timeout,
                reply_topic=topic(drone_id, channel, Direction.OUT),
            )
        except (RequestTimeout, BrokerUnavailable) as exc:
            raise ApiError(
                504,
                f"drone {drone_id} did not answer within {timeout:g} s"
                " (the request was sent: it may still take effect)",
            ) from exc

    async def control(
        self,
        drone_id: str,
        request: Any,
        timeout_s: float | None = None,
        extra: dict[str, Any] | None = None,
    ) -> dict[str, Any]:
        """Send a control request (with ``extra`` fields: who sent it, ``force``); the drone's
        answer, or 409 with its refusal: a command refused because a mission flies the drone
        is answered in the drone's own sentence (drone/direct_commands.py)."""
        await self.online_drone(drone_id)
        message = {**request.model_dump(mode="json", exclude_none=True), **(extra or {})}
        answer = await self._request(drone_id, Channel.CONTROL, message, timeout_s)
        busy = (answer.get("result") or {}).get("mission") if answer.get("ok") is False else None
        if isinstance(busy, dict) and answer.get("error"):
            raise ApiError(409, str(answer["error"]), answer=answer, mission=busy)
        if answer.get("ok") is False:
            raise ApiError(
                409,
                f"drone {drone_id} refused {message.get('command')}: {answer.get('error')}",
                answer=answer,
            )
        return answer

    async def mission(
        self, drone_id: str, request: MissionRequest, timeout_s: float | None = None
    ) -> dict[str, Any]:
        """Send a mission start/stop; answer with the drone's first progress report for it."""
        await self.online_drone(drone_id)
        message = request.model_dump(mode="json", exclude_none=True)
        answer = await self._request(drone_id, Channel.MISSION, message, timeout_s)
        if answer.get("event") == "rejected" or answer.get("ok") is False:
            raise ApiError(
                409, f"drone {drone_id} rejected the mission: {answer.get('error')}", answer=answer
            )
        return answer

    async def gear(self, drone_id: str, query: GearRequest, timeout_s: float | None = None) -> dict:
        await self.online_drone(drone_id)
        message = query.model_dump(mode="json", exclude_none=True)
        return await self._request(drone_id, Channel.GEAR, message, timeout_s)

    # -- audit ---------------------------------------------------------------------------------
    async def audit(
        self,
        who: Principal,
        drone_id: str | None,
        command: str,
        params: dict[str, Any],
        status: int,
        answer: Any,
    ) -> None:
        try:
            await self.state.audit(
                who=who.name,
                role=who.role.label,
                drone_id=drone_id,
                command=command,
                params=params,
                status=status,
                answer=answer,
            )
        except Exception:
            log.exception("could not write the audit entry for %s on %s", command, drone_id)
