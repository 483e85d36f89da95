"""A tiny stand-in drone for ground tests: heartbeats, telemetry, and answers by the seed's rules.

It speaks the wire protocol only (no flight physics), so ground behaviour can be tested alone:
an answer to every control request, gear specs and sensors, mission accepted/stopped, or silence.
"""

from __future__ import annotations

import asyncio
import contextlib
import inspect
import time
from typing import Any

from dronefleet.messaging.client import QOS_STREAM, BrokerClient
from dronefleet.messaging.codec import decode_object
from dronefleet.messaging.topics import Channel, Direction, topic


class FakeDrone:
    def __init__(
        self,
        broker_url: Any,
        drone_id: str,
        *,
        interval_s: float = 0.2,
        telemetry_hz: float = 0.0,
        answer: bool = True,
    ) -> None:
        self.drone_id = drone_id
        self.interval_s = interval_s
        self.telemetry_hz = telemetry_hz
        self.answer = answer
        self.client = BrokerClient(broker_url, f"fake-{drone_id}")
        self.received: list[dict[str, Any]] = []
        self.state = "disarmed"
        self._tasks: list[asyncio.Task[None]] = []
        self._t0 = time.monotonic()

    def _t(self, channel: Channel, direction: Direction = Direction.OUT) -> str:
        return topic(self.drone_id, channel, direction)

    async def start(self) -> FakeDrone:
        await self.client.subscribe(self._t(Channel.CONTROL, Direction.IN), self._on_control)
        await self.client.subscribe(self._t(Channel.GEAR, Direction.IN), self._on_gear)
        await self.client.subscribe(self._t(Channel.MISSION, Direction.IN), self._on_mission)
        await self.client.start()
        self._tasks.append(asyncio.create_task(self._heartbeats()))
        if self.telemetry_hz:
            self._tasks.append(asyncio.create_task(self._telemetry()))
        return self

    async def stop(self) -> None:
        for task in self._tasks:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        self._tasks.clear()
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(self.client.stop(), 5)

    def heartbeat(self) -> dict[str, Any]:
        return {
            "drone_id": self.drone_id,
            "timestamp": time.time(),
            # A sped-up sim: 5 vehicle seconds between heartbeats, ``interval_s`` of wall time
            # (the ground reads the rate from these two stamps, ground/fleet.py).
            "vehicle_time_s": (time.monotonic() - self._t0) * 5.0 / self.interval_s,
            "interval_s": 5.0,
            "position": {"lat": 40.63, "lon": -8.659, "alt_m": 10.0, "relative_alt_m": 0.0},
            "battery": {"remaining_pct": 97.0, "voltage_v": 16.4},
            "state": self.state,
            "mode": "GUIDED",
        }

    async def _heartbeats(self) -> None:
        while True:
            await self.client.publish(
                self._t(Channel.HEARTBEATS), self.heartbeat(), qos=QOS_STREAM, disposable=True
            )
            await asyncio.sleep(self.interval_s)

    async def _telemetry(self) -> None:
        n = 0
        while True:
            n += 1
            message = {
                "drone_id": self.drone_id,
                "timestamp": time.time(),
                "vehicle_time_s": n / self.telemetry_hz,
                "fields": {"alt_m": 10.0 + n % 7, "battery_pct": 100.0 - n * 0.01},
            }
            await self.client.publish(
                self._t(Channel.TELEMETRY), message, qos=QOS_STREAM, disposable=True
            )
            await asyncio.sleep(1 / self.telemetry_hz)

    async def _on_control(self, _topic: str, payload: bytes) -> None:
        data = decode_object(payload)
        self.received.append(data)
        if not self.answer:
            return
        if data.get("command") == "arm":
            self.state = "armed"
        reply = {
            "request_id": data.get("request_id"),
            "drone_id": self.drone_id,
            "command": data.get("command"),
            "ok": True,
            "result": {"echo": {k: v for k, v in data.items() if k != "request_id"}},
        }
        await self.client.publish(self._t(Channel.CONTROL), reply)

    async def _on_gear(self, _topic: str, payload: bytes) -> None:
        data = decode_object(payload)
        if not self.answer:
            return
        query = data.get("query")
        reply: dict[str, Any] = {
            "request_id": data.get("request_id"),
            "drone_id": self.drone_id,
            "query": query,
            "ok": True,
        }
        if query == "specs":
            reply["specs"] = {"frame": "quad", "max_speed_mps": 10}
        elif query == "sensors":
            reply["sensors"] = {"CO2": {"unit": "ppm"}}
        await self.client.publish(self._t(Channel.GEAR), reply)

    async def _on_mission(self, _topic: str, payload: bytes) -> None:
        data = decode_object(payload)
        self.received.append(data)
        if not self.answer:
            return
        event = "accepted" if data.get("action", "start") == "start" else "stopped"
        reply = {
            "drone_id": self.drone_id,
            "mission_id": data.get("mission_id") or "",
            "request_id": data.get("request_id"),
            "event": event,
            "kind": "progress",
        }
        await self.client.publish(self._t(Channel.MISSION), reply)


async def eventually(predicate, timeout_s: float = 5.0, poll_s: float = 0.05):
    """Poll ``predicate`` (sync or async) until it gives something true; return that."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = predicate()
        if inspect.isawaitable(value):
            value = await value
        if value:
            return value
        await asyncio.sleep(poll_s)
    raise AssertionError(f"condition not met within {timeout_s} s")
