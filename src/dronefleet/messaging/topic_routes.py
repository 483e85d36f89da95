"""A broker client's routing: the subscriptions a topic goes to, the filters held at the broker.

MQTT filter matching (``+``, ``#``) is done as the broker does it: paho's trie of filters, built
once per client (paho's topic_matches_sub builds one per call, which a flood made the hot spot).
"""

from __future__ import annotations

from collections.abc import Iterable

from paho.mqtt.matcher import MQTTMatcher

from dronefleet.messaging.subscriptions import Subscription

#: Topics (of at most ROUTE_CACHE_TOPIC chars) whose matching subscriptions a client remembers;
#: beyond it the memory starts again, so a flood of junk topics cannot grow it (about 20 MB).
#: A client subscribed to ``+/heartbeats/out`` of 10,000 drones holds 10,000 topics: at a limit
#: of 10,000 the memory was emptied every few seconds and most messages matched afresh (a
#: third of the time paho's messages took on a leader of 10,000 drones, issue 27).
ROUTE_CACHE_LIMIT = 100_000
ROUTE_CACHE_TOPIC = 128


def covers(wide: str, narrow: str) -> bool:
    """Whether every topic the MQTT filter ``narrow`` matches is matched by ``wide`` too."""
    w, n = wide.split("/"), narrow.split("/")
    for i, level in enumerate(w):
        if level == "#":
            return True
        if i >= len(n) or n[i] == "#" or (level != "+" and level != n[i]):
            return False
    return len(w) == len(n)


def broker_filters(subs: Iterable[Subscription]) -> dict[str, int]:
    """The filters to hold at the broker: each subscription's, less those another filter of
    this client covers (at the highest QoS of what it covers). A broker delivers a message
    once per matching subscription of a client (Mosquitto's allow_duplicate_messages, NATS),
    and every copy is handed to every matching subscription here: a drone whose logger
    holds ``<id>/#`` beside its controller's ``<id>/mission/in`` started each mission twice.
    A narrowed subscription (``at_broker``: thousands of one drone's topics) is held as its
    filters, each compared only with the client's whole patterns (few), never with each other."""
    wanted: dict[str, int] = {}
    narrowed: dict[str, int] = {}
    for sub in subs:
        if sub.at_broker is None:
            wanted[sub.pattern] = max(wanted.get(sub.pattern, 0), sub.qos)
        else:
            for one in sub.at_broker:
                narrowed[one] = max(narrowed.get(one, 0), sub.qos)
    held = {
        pattern: max(q for other, q in wanted.items() if covers(pattern, other))
        for pattern in wanted
        if not any(other != pattern and covers(other, pattern) for other in wanted)
    }
    for one, qos in narrowed.items():
        wider = [pattern for pattern in held if covers(pattern, one)]
        if not wider:
            held[one] = qos
        for pattern in wider:
            held[pattern] = max(held[pattern], qos)
    return held


class TopicRoutes:
    """The subscriptions each topic matches, remembered until the next subscribe (a client
    sees few topics, each many times; junk topics only refill a bounded memory)."""

    def __init__(self) -> None:
        self._matcher = MQTTMatcher()  # filter -> its subscriptions
        self._routes: dict[str, tuple[Subscription, ...]] = {}  # topic -> matching, remembered

    def add(self, sub: Subscription) -> None:
        """Route what ``sub``'s filter matches to it too, from the next message on."""
        pattern = sub.pattern
        try:
            self._matcher[pattern].append(sub)
        except KeyError:
            self._matcher[pattern] = [sub]
        if "+" in pattern or "#" in pattern:
            self._routes.clear()
        else:
            self._routes.pop(pattern, None)  # the one topic it matches

    def of(self, topic_name: str) -> tuple[Subscription, ...]:
        """The subscriptions ``topic_name`` matches."""
        subs = self._routes.get(topic_name)
        if subs is None:
            subs = self._subscriptions_of(topic_name)
        return subs

    def _subscriptions_of(self, topic_name: str) -> tuple[Subscription, ...]:
        subs = tuple(sub for subs in self._matcher.iter_match(topic_name) for sub in subs)
        if len(topic_name) <= ROUTE_CACHE_TOPIC:
            if len(self._routes) >= ROUTE_CACHE_LIMIT:
                self._routes.clear()
            self._routes[topic_name] = subs
        return subs
