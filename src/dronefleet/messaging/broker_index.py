"""amqtt with a topic index: each broadcast visits only the subscriptions that match it.

amqtt 0.12.1 (pinned in pyproject.toml) routes a published message by scanning every
subscription filter the broker holds and formats a debug line for each filter that does not
match. A fleet of N drones holds about 5 N filters (each drone's ``control/in``, ``mission/in``,
``gear/in``, and the fail-safe's own ``telemetry/out`` and ``mission/out``), so each message cost
O(N) and the fleet O(N²): profiled with 100 drones on virtual time, ``_run_broadcast`` and
``_matches`` took 36 % of the process (bench/sim_scale.py, issue 9).

:class:`IndexedBroker` keeps amqtt's own routing rules — its matcher (``Broker._matches``), its
topic-filter plugins, retention for offline persistent sessions, one publish task per target —
and only changes *which* filters are visited: a plain filter is found by a dict lookup, and only
the few wildcard filters are matched (with amqtt's matcher, cached per topic). Two more O(N)
costs per connection and subscription, from debug lines amqtt formats eagerly, are avoided.

Why not another broker: Mosquitto is faster but is a separate process, which virtual time cannot
wait for (docs/DESIGN.md §4); the other pure-Python brokers on PyPI are unmaintained. Why not a
patch of amqtt's module: a subclass keeps the change visible and local to the embedded broker.
"""

from __future__ import annotations

import asyncio
from collections import deque
from collections.abc import Callable, Iterator
from typing import Any

from amqtt.broker import Broker
from amqtt.contexts import Action
from amqtt.mqtt.constants import QOS_1, QOS_2
from amqtt.session import Session


class _Filters(dict[str, list[Any]]):
    """amqtt's ``filter -> [(session, qos)]`` map, with its wildcard filters kept apart.

    A filter without ``+`` or ``#`` matches only the topic equal to it, so it is found by a dict
    lookup; only the few wildcard filters (the ground's ``+/telemetry/out`` and the like) are
    matched one by one, and their matches are cached per topic until that set changes."""

    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        self.wildcards: set[str] = {f for f in self if _is_wildcard(f)}
        self.wildcard_version = 0

    def __setitem__(self, key: str, value: list[Any]) -> None:
        if key not in self and _is_wildcard(key):
            self.wildcards.add(key)
            self.wildcard_version += 1
        super().__setitem__(key, value)

    def __delitem__(self, key: str) -> None:
        if key in self.wildcards:
            self.wildcards.discard(key)
            self.wildcard_version += 1
        super().__delitem__(key)

    def clear(self) -> None:
        self.wildcards.clear()
        self.wildcard_version += 1
        super().clear()

    def pop(self, key: str, *default: Any) -> Any:
        if key in self.wildcards:
            self.wildcards.discard(key)
            self.wildcard_version += 1
        return super().pop(key, *default)

    def __iter__(self) -> Iterator[str]:
        # A snapshot: amqtt 0.12.1 iterates the filters with an ``await`` in the loop body (the
        # retained messages of a reconnecting persistent session, broker.py line 601), so a
        # SUBSCRIBE from another client meanwhile failed that connection with "dictionary
        # changed size during iteration" and the client never got its CONNACK (seen when a
        # restarted ground's clients reconnect together).
        return iter(list(dict.keys(self)))

    def __repr__(self) -> str:
        # amqtt logs repr(subscriptions) at DEBUG after every SUBSCRIBE, formatted eagerly:
        # with thousands of filters that alone was O(N) per subscription.
        return f"<{len(self)} subscription filters, {len(self.wildcards)} with wildcards>"


def _is_wildcard(topic_filter: str) -> bool:
    return "+" in topic_filter or "#" in topic_filter


class IndexedBroker(Broker):
    """amqtt's broker, routing each topic through an index of the filters that match it, and
    checking topics with ``topic_rule(user, topic, action)`` when given: amqtt asks its topic
    plugins through a task per plugin per check, for every delivery too, which cost more than
    the routing (what a client may hear is decided when it subscribes, so deliveries pass)."""

    def __init__(
        self,
        *args: Any,
        topic_rule: Callable[[str | None, str, Action], bool] | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(*args, **kwargs)
        self._topic_rule = topic_rule
        self._subscriptions: dict[str, list[Any]] = _Filters(self._subscriptions)
        self._wildcard_cache: dict[str, tuple[str, ...]] = {}
        self._wildcard_cache_version = -1

    async def _topic_filtering(self, session: Session, topic: str, action: Action) -> bool:
        if self._topic_rule is None:
            return bool(await super()._topic_filtering(session, topic, action))
        if action is Action.RECEIVE:
            return True
        return self._topic_rule(session.username if session else None, topic, action)

    def _filters_for(self, topic: str) -> list[str]:
        filters = self._subscriptions
        assert isinstance(filters, _Filters)
        if self._wildcard_cache_version != filters.wildcard_version:
            self._wildcard_cache.clear()
            self._wildcard_cache_version = filters.wildcard_version
        wild = self._wildcard_cache.get(topic)
        if wild is None:
            wild = tuple(f for f in filters.wildcards if self._matches(topic, f))
            if len(self._wildcard_cache) > 100_000:  # a flood of distinct topics: start afresh
                self._wildcard_cache.clear()
            self._wildcard_cache[topic] = wild
        exact = [topic] if topic in filters else []  # amqtt: a plain filter equals its topic
        return exact + list(wild)

    async def _publish_retained_messages_for_subscription(
        self, subscription: tuple[str, int], session: Session
    ) -> None:
        # amqtt calls this for every filter in the broker at every CONNECT; with no retained
        # message there is nothing to send, and its debug lines made each connect O(filters).
        if self._retained_messages:
            await super()._publish_retained_messages_for_subscription(subscription, session)

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
