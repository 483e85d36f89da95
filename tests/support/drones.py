"""Drone processes started with the real CLI, and an operator that talks to them over MQTT."""

from __future__ import annotations

import asyncio
import contextlib
from collections import defaultdict
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

from dronefleet.messaging import topics
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.codec import decode_object
from dronefleet.messaging.common import new_request_id
from dronefleet.messaging.rpc import Requester
from dronefleet.messaging.topics import Channel, Direction
from dronefleet.messaging.url import BrokerUrl
from support.processes import dronefleet_process


@contextlib.asynccontextmanager
async def drone_process(
    broker: BrokerUrl, drone_id: str, *args: str, ready_timeout_s: float = 30.0
) -> AsyncIterator[asyncio.subprocess.Process]:
    """``dronefleet drone --id ID --broker URL --fc sim ...`` until it says ready."""
    command = ("drone", "--id", drone_id, "--broker", broker.full(), "--fc", "sim", *args)
    async with dronefleet_process(*command, ready="ready", timeout_s=ready_timeout_s) as (proc, _):
        yield proc


class Operator:
    """A ground-side stand-in for tests: sends commands and missions, records what comes back."""

    def __init__(self, broker: BrokerUrl, name: str = "operator") -> None:
        self.client = BrokerClient(broker, f"{name}-{new_request_id()[:8]}")
        self.requester = Requester(self.client)
        self.received: dict[str, list[dict[str, Any]]] = defaultdict(list)
        self._events: dict[str, asyncio.Event] = defaultdict(asyncio.Event)

    async def __aenter__(self) -> Operator:
        await self.client.start()
        for channel in (Channel.MISSION, Channel.ALARMS, Channel.HEARTBEATS, Channel.CONTROL):
            await self.client.subscribe(topics.any_drone(channel), self._record)
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.client.stop()

    async def _record(self, topic_name: str, payload: bytes) -> None:
        key = topic_name.split("/", 1)[1]
        self.received[key].append(decode_object(payload))
        self._events[key].set()

    def progress(self, mission_id: str | None = None) -> list[dict[str, Any]]:
        return [
            m for m in self.received["mission/out"] if mission_id in (None, m.get("mission_id"))
        ]

    def alarms(self, level: str | None = None) -> list[dict[str, Any]]:
        return [a for a in self.received["alarms/out"] if level in (None, a["level"])]

    async def command(
        self, drone_id: str, timeout_s: float = 20.0, **fields: Any
    ) -> dict[str, Any]:
        return await self.requester.request(
            topics.topic(drone_id, Channel.CONTROL, Direction.IN),
            topics.topic(drone_id, Channel.CONTROL, Direction.OUT),
            fields,
            timeout_s=timeout_s,
        )

    async def send_mission(self, drone_id: str, **request: Any) -> None:
        await self.client.publish(topics.topic(drone_id, Channel.MISSION, Direction.IN), request)

    async def wait_for(self, predicate, timeout_s: float = 60.0, key: str = "mission/out") -> Any:
        """Wait until ``predicate()`` is truthy, re-checking on each message on ``key``."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        while not (result := predicate()):
            remaining = deadline - loop.time()
            if remaining <= 0:
                raise TimeoutError(f"condition not met within {timeout_s} s")
            event = self._events[key]
            event.clear()
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(min(remaining, 0.5)):
                    await event.wait()
        return result

    async def heartbeat(self, drone_id: str, timeout_s: float = 30.0) -> dict[str, Any]:
        def latest():
            beats = [h for h in self.received["heartbeats/out"] if h["drone_id"] == drone_id]
            return beats[-1] if beats else None

        return await self.wait_for(latest, timeout_s, key="heartbeats/out")


def read_jsonl(path: Path) -> list[dict[str, Any]]:
    import orjson

    return [orjson.loads(line) for line in path.read_text().splitlines() if line.strip()]


async def until_mid_leg(vehicle: Any, left_m: float = 15.0, flown_m: float = 8.0) -> None:
    """Wait until a simulated vehicle is flying a leg with ``left_m`` or more to go and speed,
    having flown ``flown_m`` of it already.

    A pilot's switch taken while the drone is sending its next ``navigate`` races with it: the
    later of the two wins on the autopilot as on a real one, and a test that switched "after the
    4th step" lost that race on a loaded host. Just after the target is set, the drone may still
    be reading its autopilot's acknowledgement (UAVTalk: the Waypoint write's ACK, then, in the
    same read, the FlightStatus the switch changed): the full suite on a loaded host lost that
    race twice. ``flown_m`` into the leg (1-2 vehicle s), the drone only waits for the flight,
    so the switch is the pilot's alone. Checked and switched with no await between (the
    simulator runs on this event loop)."""
    leg_target, leg_start = None, None
    while True:
        target = vehicle.target_ned
        if target != leg_target:
            leg_target, leg_start = target, vehicle.position_ned
        moving = vehicle.velocity_ned.horizontal_m > 1.0
        if (
            target is not None
            and leg_start is not None
            and moving
            and (vehicle.position_ned - leg_start).horizontal_m >= flown_m
            and (target - vehicle.position_ned).horizontal_m >= left_m
        ):
            return
        await asyncio.sleep(0.005)
