"""What each broker user may publish and subscribe to (issue 12): the one set of rules.

- A **ground** service publishes only commands (``<any drone>/<channel>/in``) and its own
  ``ground/...`` topics, and subscribes only to what drones send (``<any>/<channel>/out``) and
  ``ground/...``. It cannot speak for a drone.
- A **drone** speaks only for itself. On a shared broker (the embedded one, where a drone's own
  parts talk to each other through it) it may use anything under ``<its id>/``; on the ground's
  Mosquitto, which its bridge reaches, only ``<its id>/+/out`` out and ``<its id>/+/in`` in.

``mosquitto_files`` writes the same rules as a Mosquitto password file and ACL file.
"""

from __future__ import annotations

from dronefleet.messaging.broker_users import BrokerRole, BrokerUser, BrokerUsers
from dronefleet.messaging.topics import GROUND_PREFIX, Channel, Direction

_CHANNELS = frozenset(c.value for c in Channel)


def _drone_topic(levels: list[str], direction: Direction, *, wild: bool) -> bool:
    """``<id>/<channel>/<direction>``, the first two levels possibly ``+`` when ``wild``."""
    if len(levels) != 3 or levels[2] != direction.value:
        return False
    first_ok = levels[0] not in ("#", GROUND_PREFIX) and (wild or levels[0] != "+")
    return first_ok and (levels[1] in _CHANNELS or (wild and levels[1] == "+"))


def _allowed(
    user: BrokerUser, topic: str, ground: Direction, drone: Direction, *, wild: bool, shared: bool
) -> bool:
    levels = topic.split("/")
    if user.role is BrokerRole.GROUND:
        return levels[0] == GROUND_PREFIX or _drone_topic(levels, ground, wild=wild)
    if shared:
        return levels[0] == user.name and len(levels) > 1
    return levels[0] == user.name and _drone_topic(levels, drone, wild=wild)


def may_publish(user: BrokerUser, topic: str, *, shared: bool = True) -> bool:
    """Ground: commands to any drone; drone: its own messages (``shared``: all its topics)."""
    return _allowed(user, topic, Direction.IN, Direction.OUT, wild=False, shared=shared)


def may_subscribe(user: BrokerUser, topic_filter: str, *, shared: bool = True) -> bool:
    """Ground: what drones send; drone: its own requests (``shared``: all its topics)."""
    return _allowed(user, topic_filter, Direction.OUT, Direction.IN, wild=True, shared=shared)


def mosquitto_files(users: BrokerUsers) -> tuple[str, str]:
    """(password file, ACL file) for a Mosquitto that the drones reach by their bridges."""
    passwords = "".join(f"{u.name}:{u.password_hash}\n" for u in users.all())
    acl = [
        "# Written by `dronefleet broker-config` (messaging/broker_acl.py). Anonymous clients",
        "# are refused by the listener (allow_anonymous false); these are the users' rights.",
    ]
    for u in users.all():
        acl.append(f"\nuser {u.name}")
        if u.role is BrokerRole.GROUND:
            acl += [
                "topic write +/+/in",
                "topic read +/+/out",
                f"topic readwrite {GROUND_PREFIX}/#",
            ]
        else:
            acl += [f"topic write {u.name}/+/out", f"topic read {u.name}/+/in"]
    return passwords, "\n".join(acl) + "\n"
