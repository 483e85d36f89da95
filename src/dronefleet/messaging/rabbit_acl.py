"""The broker rules of messaging/broker_acl.py as a RabbitMQ definitions file (issue 12).

RabbitMQ's MQTT adapter publishes to the ``amq.topic`` exchange with the MQTT topic as routing
key, ``/`` turned into ``.`` (``QUAD_1/control/in`` is ``QUAD_1.control.in``; a subscription's
``+`` is ``*``, ``#`` stays ``#``). Topic permissions (RabbitMQ 3.7+) are regular expressions over
those keys, checked on every publish (write) and subscription (read); so:

- a **drone** connects straight to the ground's RabbitMQ (it has no bridge there) and has what
  its parts use there, as on the ground's Mosquitto (``broker_acl.drone_rights``): it writes
  ``<id>.<channel>.out`` and ``<id>.gear.in`` (the Drone Controller asks its own Gear Manager),
  and reads only keys under its own id, ``^<id>\\.``;
- a **ground** service writes only ``<any>.<channel>.in`` and ``ground.…``, reads only
  ``<any>.<channel>.out`` and ``ground.…``.

Resource permissions let each user declare and use only its own MQTT subscription queues
(``mqtt-subscription-<client id>qos0|1``; a drone's client ids start with its id) and the topic
exchange. Users carry RabbitMQ's own hash of their password (``rabbit_password_hashing_sha256``),
made when the user is (messaging/broker_users.py), so no password is written anywhere.

``dronefleet broker-config --broker rabbitmq --vhost V`` writes it; ``rabbitmqctl
import_definitions FILE`` loads it; clients then log in as ``V:<user>``.
"""

from __future__ import annotations

import re
from typing import Any

from dronefleet.errors import InvalidInput
from dronefleet.messaging.broker_acl import drone_rights
from dronefleet.messaging.broker_users import BrokerRole, BrokerUser, BrokerUsers
from dronefleet.messaging.topics import GROUND_PREFIX, Channel

_CHANNELS = "|".join(sorted(c.value for c in Channel))
EXCHANGE = "amq.topic"


def _ground(direction: str) -> str:
    return rf"^([^.]+\.({_CHANNELS})\.{direction}|{GROUND_PREFIX}\..+)$"


def _routing_keys(patterns: tuple[str, ...]) -> str:
    """MQTT topic patterns as one regular expression over RabbitMQ routing keys (``/`` is ``.``;
    a subscription's ``+`` arrives as ``*``, its ``#`` as ``#``): ``+`` is one level, ``#`` the
    rest (at least one level)."""
    levels = {"+": r"[^.]+", "#": r".+"}
    keys = (r"\.".join(levels.get(p, re.escape(p)) for p in t.split("/")) for t in patterns)
    return rf"^({'|'.join(keys)})$"


def _rights(user: BrokerUser) -> tuple[dict[str, str], dict[str, str]]:
    """(resource permissions, topic permissions) of ``user``."""
    if user.role is BrokerRole.GROUND:
        queues = r"mqtt-subscription-.+"
        topics = {"write": _ground("in"), "read": _ground("out")}
    else:
        own = re.escape(user.name)
        queues = rf"mqtt-subscription-{own}-.+"
        publish, subscribe = drone_rights(user.name)
        topics = {"write": _routing_keys(publish), "read": _routing_keys(subscribe)}
    resources = {
        "configure": rf"^{queues}$",
        "write": rf"^({re.escape(EXCHANGE)}|{queues})$",
        "read": rf"^({re.escape(EXCHANGE)}|{queues})$",
    }
    return resources, topics


def _check_vhost(vhost: str) -> str:
    if not vhost or ":" in vhost:
        raise InvalidInput(f"vhost {vhost!r}: non-empty and without ':' (clients log in as V:USER)")
    return vhost


def rabbit_login(vhost: str, user: str) -> str:
    """The MQTT user name of ``user`` in ``vhost``: ``vhost:user`` (RabbitMQ's MQTT adapter
    splits it at the first ``:``; in a broker URL it is written ``vhost%3Auser``)."""
    return f"{_check_vhost(vhost)}:{user}"


def rabbitmq_definitions(users: BrokerUsers, vhost: str) -> dict[str, Any]:
    """A definitions document (``rabbitmqctl import_definitions``) for ``users`` in ``vhost``."""
    _check_vhost(vhost)
    missing = [u.name for u in users.all() if not u.rabbit_hash]
    if missing:
        raise InvalidInput(
            f"no RabbitMQ password hash kept for {', '.join(missing)}: users made before it was "
            "kept must be made again (dronefleet credentials add-drone / add-ground)"
        )
    definitions: dict[str, Any] = {
        "vhosts": [{"name": vhost}],
        "users": [],
        "permissions": [],
        "topic_permissions": [],
    }
    for user in users.all():
        definitions["users"].append(
            {
                "name": user.name,
                "password_hash": user.rabbit_hash,
                "hashing_algorithm": "rabbit_password_hashing_sha256",
                "tags": [],
            }
        )
        resources, topics = _rights(user)
        definitions["permissions"].append({"user": user.name, "vhost": vhost, **resources})
        definitions["topic_permissions"].append(
            {"user": user.name, "vhost": vhost, "exchange": EXCHANGE, **topics}
        )
    return definitions
