"""What each broker user may publish and subscribe to (issue 12): the one set of rules.

- A **ground** service publishes only commands (``<any drone>/<channel>/in``) and its own
  ``ground/...`` topics, and subscribes only to what drones send (``<any>/<channel>/out``) and
  ``ground/...``. It cannot speak for a drone.
- A **drone** speaks only for itself. On a shared broker (the embedded one) it may use anything
  under ``<its id>/``. On the ground's broker (Mosquitto, which its bridge reaches or its parts
  connect to straight; RabbitMQ, messaging/rabbit_acl.py) it has exactly what its own parts use
  (:func:`drone_rights`): it publishes its messages, ``<its id>/+/out``, and the Drone
  Controller's questions to its own Gear Manager, ``<its id>/gear/in`` (a ``takepic``); it
  subscribes under ``<its id>/`` only: its requests (``+/in``), its Gear Manager's answers
  (``gear/out``), its own progress for the fail-safe (``mission/out``) and, for the Logger,
  everything of its own (``<its id>/#``).

``mosquitto_files`` writes the same rules as a Mosquitto password file and ACL file.
"""

from __future__ import annotations

from dronefleet.messaging.broker_users import BrokerRole, BrokerUser, BrokerUsers
from dronefleet.messaging.topics import GROUND_PREFIX, Channel, Direction, check_drone_id

_CHANNELS = frozenset(c.value for c in Channel)


def _drone_topic(levels: list[str], direction: Direction, *, wild: bool) -> bool:
    """``<id>/<channel>/<direction>``, the first two levels possibly ``+`` when ``wild``."""
    if len(levels) != 3 or levels[2] != direction.value:
        return False
    first_ok = levels[0] not in ("#", GROUND_PREFIX) and (wild or levels[0] != "+")
    return first_ok and (levels[1] in _CHANNELS or (wild and levels[1] == "+"))


def drone_rights(drone_id: str) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(publish, subscribe) topic patterns of drone ``drone_id`` on the ground's broker: what
    its own parts use (drone/controller.py, gear.py, mission_worker.py, failsafe.py,
    logger.py), under its own id and nothing else."""
    own = check_drone_id(drone_id)
    publish = (f"{own}/+/{Direction.OUT}", f"{own}/{Channel.GEAR}/{Direction.IN}")
    return publish, (f"{own}/#",)


def _within(levels: list[str], pattern: list[str]) -> bool:
    """Whether a topic (or a subscription filter) lies within an ACL ``pattern``, as Mosquitto
    decides it: ``#`` covers the rest, ``+`` one level (a filter's ``+`` too)."""
    for i, level in enumerate(levels):
        if i >= len(pattern):
            return False
        if pattern[i] == "#":
            return True
        if pattern[i] != level and not (pattern[i] == "+" and level != "#"):
            return False
    return len(pattern) == len(levels) or pattern[len(levels) :] == ["#"]


def _allowed(user: BrokerUser, topic: str, ground: Direction, *, wild: bool, shared: bool) -> bool:
    levels = topic.split("/")
    if user.role is BrokerRole.GROUND:
        return levels[0] == GROUND_PREFIX or _drone_topic(levels, ground, wild=wild)
    if levels[0] != user.name or len(levels) < 2:
        return False
    if shared:
        return True
    publish, subscribe = drone_rights(user.name)
    return any(_within(levels, p.split("/")) for p in (subscribe if wild else publish))


def may_publish(user: BrokerUser, topic: str, *, shared: bool = True) -> bool:
    """Ground: commands to any drone; drone: its own messages and questions to its own gear
    (``shared``: all its topics)."""
    return _allowed(user, topic, Direction.IN, wild=False, shared=shared)


def may_subscribe(user: BrokerUser, topic_filter: str, *, shared: bool = True) -> bool:
    """Ground: what drones send; drone: topics under its own id."""
    return _allowed(user, topic_filter, Direction.OUT, wild=True, shared=shared)


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
            publish, subscribe = drone_rights(u.name)
            acl += [f"topic write {p}" for p in publish]
            acl += [f"topic read {p}" for p in subscribe]
    return passwords, "\n".join(acl) + "\n"
