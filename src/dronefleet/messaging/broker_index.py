"""amqtt with a topic index: each broadcast visits only the subscriptions that match it.

amqtt 0.12.1 (pinned in pyproject.toml) routes a published message by scanning every
subscription filter the broker holds and formats a debug line for each filter that does not
match. A fleet of N drones holds about 5 N filters (each drone's ``control/in``, ``mission/in``,
``gear/in``, and the fail-safe's own ``telemetry/out`` and ``mission/out``), so each message cost
O(N) and the fleet O(N²): profiled with 100 drones on virtual time, ``_run_broadcast`` and
``_matches`` took 36 % of the process (bench/sim_scale.py, issue 9).

:class:`IndexedBroker` keeps amqtt's own routing rules — its matcher (``Broker._matches``), its
topic-filter plugins, retention for offline persistent sessions, one publish task per target —
and only changes *which* filters are visited: the filters matching a topic are computed once
(with amqtt's matcher) and cached until the set of filters changes.

Why not another broker: Mosquitto is faster but is a separate process, which virtual time cannot
wait for (docs/DESIGN.md §4); the other pure-Python brokers on PyPI are unmaintained. Why not a
patch of amqtt's module: a subclass keeps the change visible and local to the embedded broker.
"""

from __future__ import annotations

import asyncio
from collections import deque
from typing import Any

from amqtt.broker import Broker
from amqtt.contexts import Action
from amqtt.mqtt.constants import QOS_1, QOS_2


class _Filters(dict[str, list[Any]]):
    """amqtt's ``filter -> [(session, qos)]`` map, counting changes to its set of filters."""

    version = 0

    def __setitem__(self, key: str, value: list[Any]) -> None:
        if key not in self:
            self.version += 1
        super().__setitem__(key, value)

    def __delitem__(self, key: str) -> None:
        self.version += 1
        super().__delitem__(key)

    def clear(self) -> None:
        self.version += 1
        super().clear()

    def pop(self, key: str, *default: Any) -> Any:
        self.version += 1
        return super().pop(key, *default)


class IndexedBroker(Broker):
    """amqtt's broker, routing each topic through a cached list of the filters that match it."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._subscriptions = _Filters(self._subscriptions)
        self._route_cache: dict[str, tuple[str, ...]] = {}
        self._route_version = -1

    def _filters_for(self, topic: str) -> tuple[str, ...]:
        filters = self._subscriptions
        assert isinstance(filters, _Filters)
        if self._route_version != filters.version:
            self._route_cache.clear()
            self._route_version = filters.version
        found = self._route_cache.get(topic)
        if found is None:
            found = tuple(f for f in filters if self._matches(topic, f))
            if len(self._route_cache) > 100_000:  # a flood of distinct topics: start afresh
                self._route_cache.clear()
            self._route_cache[topic] = found
        return found

    async def _run_broadcast(self, running_tasks: deque[Any]) -> None:
        broadcast = await self._broadcast_queue.get()
        topic = broadcast["topic"]
        for k_filter in self._filters_for(topic):
            for target_session, sub_qos in list(self._subscriptions.get(k_filter, ())):
                qos = broadcast.get("qos", sub_qos)
                if not await self._topic_filtering(
                    target_session, topic=topic, action=Action.RECEIVE
                ):
                    continue
                state = target_session.transitions.state
                if state != "connected":
                    # Kept for a persistent session that is away, as amqtt does [MQTT-3.1.2.4].
                    if (
                        not target_session.clean_session
                        and qos in (QOS_1, QOS_2)
                        and not target_session.is_anonymous
                    ):
                        await self._retain_broadcast_message(broadcast, qos, target_session)
                    continue
                handler = self._get_handler(target_session)
                if handler:
                    task = asyncio.ensure_future(
                        handler.mqtt_publish(topic, broadcast["data"], qos, retain=False)
                    )
                    running_tasks.append(task)
