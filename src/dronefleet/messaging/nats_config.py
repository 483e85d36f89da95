"""The broker rules of messaging/broker_acl.py as a NATS server configuration (issue 25).

NATS (2.10 and newer) speaks MQTT 3.1.1 on a listener of its own and maps an MQTT topic to a NATS
subject: ``/`` becomes ``.``, a ``.`` inside a level becomes ``//``, a filter's ``+`` is ``*``
and ``#`` is ``>``; so ``QUAD_1/control/in`` is ``QUAD_1.control.in``. A filter ``a/#`` is
subscribed as both ``a`` and ``a.>`` (MQTT's ``#`` matches its parent level too), so whoever may
subscribe ``a/#`` needs both. Users' permissions are over those subjects, checked at every
publish (a forbidden one is dropped), subscription (refused in the SUBACK) and Will (a CONNECT
whose Will the user may not publish is refused). The rules:

- a **ground** publishes commands (``<any>/<channel>/in``, one subject per channel) and
  ``ground/...``, subscribes what drones send (``*.*.out``: NATS cannot say "a channel or +",
  so a ground may also hear an unknown channel a drone sends on) and ``ground/...``; the same
  user over NATS's own protocol may take ``*.telemetry.out`` in a queue group (a subscribe
  permission without a queue name allows any queue: the replicas' shared ingestion,
  ground/telemetry/shared_ingest.py);
- a **drone**, on a ``shared`` broker (the embedded one, where its own parts talk to each other
  through it), publishes and subscribes anything under ``<its id>/``; on the ground's broker
  (not shared), it has the rights ``broker_acl.mosquitto_files`` gives it, read from the ACL
  that writes, so the two never differ.

Passwords appear only as the users' bcrypt hashes (``BrokerUser.nats_hash``). All users are in
one account, ``FLEET``, with JetStream, which MQTT needs for QoS 1, persistent sessions and
retained messages. ``anonymous=True`` lets a client without credentials in as a user allowed
everything (tests that ask for it).
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass, field

from dronefleet.errors import InvalidInput
from dronefleet.messaging.broker_acl import mosquitto_files
from dronefleet.messaging.broker_users import BrokerRole, BrokerUser, BrokerUsers
from dronefleet.messaging.topics import GROUND_PREFIX, Channel, Direction

ACCOUNT = "FLEET"
#: The user an anonymous client becomes (with ``anonymous=True``). A ':' is in no drone id and no
#: ground user name (messaging/broker_users.py), so no real user can be it.
ANONYMOUS_USER = "anonymous:"
#: NATS with no users at all asks no client for credentials, so a broker with none yet (users
#: come later, by reload) has this one, locked: a well-formed bcrypt hash made of no password
#: (finding one that matches it is as hard as inverting bcrypt), allowed nothing.
LOCKED_USER = "nobody:"
LOCKED_HASH = "$2a$10$" + "." * 53
#: How long NATS waits for a QoS 1 message's PUBACK before it sends it again. NATS's default is
#: 30 s; the fleet's commands and alarms are worth resending sooner to a client that took one and
#: then went quiet or was cut (its persistent session gets it again on reconnect either way).
ACK_WAIT = "2s"
#: Largest message. NATS's default is 1 MB; the largest mission (messaging/missions.py) is about
#: 1.5 MB and the broker client drops anything over 2 MB itself (messaging/client.py), which it
#: must receive to count it. NATS warns above 8 MB.
MAX_PAYLOAD = "8MB"


@dataclass(frozen=True)
class Permissions:
    """NATS subjects a user may publish to and subscribe to (``allow`` lists)."""

    publish: tuple[str, ...]
    subscribe: tuple[str, ...]


@dataclass(frozen=True)
class NatsCluster:
    """This node's part of a NATS cluster (each node gets its own configuration)."""

    name: str  # the cluster's, the same on every node
    server_name: str  # this node's, unique in the cluster
    host: str  # where this node listens for routes from the others
    port: int
    routes: tuple[str, ...] = field(default=())  # the other nodes: "nats-route://host:port"
    stream_replicas: int = 3  # copies of each MQTT stream (sessions, QoS 1, retained)


def nats_subject(mqtt: str) -> list[str]:
    """The NATS subjects an MQTT topic or filter stands for (two for ``a/#``: ``a``, ``a.>``)."""
    levels = mqtt.split("/")
    tokens = ["*" if lv == "+" else ">" if lv == "#" else lv.replace(".", "//") for lv in levels]
    subject = ".".join(tokens)
    if tokens[-1] == ">" and len(tokens) > 1:
        return [".".join(tokens[:-1]), subject]
    return [subject]


def mqtt_topic(subject: str) -> str:
    """The MQTT topic of a NATS subject a message came on (:func:`nats_subject` undone)."""
    if "//" not in subject:  # no '.' in the topic: nearly every message, at one replace
        return subject.replace(".", "/")
    return "/".join(token.replace("//", ".") for token in subject.split("."))


def _subjects(patterns: Iterable[str]) -> tuple[str, ...]:
    seen: dict[str, None] = {}
    for pattern in patterns:
        seen.update(dict.fromkeys(nats_subject(pattern)))
    return tuple(seen)


def _mosquitto_rules(user: BrokerUser) -> tuple[list[str], list[str]]:
    """(write, read) patterns of ``user`` in the ACL file ``mosquitto_files`` writes."""
    one = BrokerUsers()
    one.add_hashed(user)
    _, acl = mosquitto_files(one)
    write: list[str] = []
    read: list[str] = []
    for line in acl.splitlines():
        words = line.split()
        if not words or words[0].startswith("#") or line.startswith("user "):
            continue
        if words[0] != "topic" or len(words) != 3 or words[1] not in ("read", "write", "readwrite"):
            raise InvalidInput(f"nats_config cannot translate the Mosquitto ACL line {line!r}")
        if "write" in words[1]:
            write.append(words[2])
        if "read" in words[1]:
            read.append(words[2])
    return write, read


def permissions(user: BrokerUser, *, shared: bool = True) -> Permissions:
    """What ``user`` may do, as NATS subjects (see the module's docstring)."""
    ground = f"{GROUND_PREFIX}/#"
    if user.role is BrokerRole.GROUND:  # the same on every broker
        write = [f"+/{channel}/{Direction.IN}" for channel in Channel] + [ground]
        read = [f"+/+/{Direction.OUT}", ground]
    elif not shared:
        write, read = _mosquitto_rules(user)
    else:
        write = read = [f"{user.name}/#"]
    publish = _subjects(write)
    if shared and user.role is BrokerRole.DRONE:
        # broker_acl: a drone publishes under its id, never on the bare id (which ``<id>/#``'s
        # parent subject would allow); subscribing ``<id>/#`` needs the parent all the same.
        publish = tuple(s for s in publish if s != nats_subject(user.name)[0])
    return Permissions(publish=publish, subscribe=_subjects(read))


def _q(text: str) -> str:
    return json.dumps(text)  # NATS reads JSON's double-quoted strings with their escapes


def _rule(subjects: tuple[str, ...]) -> str:
    # An empty allow list would be no list at all, to NATS: allow everything.
    if not subjects:
        return '{deny: [">"]}'
    return f"{{allow: [{', '.join(_q(s) for s in subjects)}]}}"


def _user_entry(name: str, password_hash: str | None, perms: Permissions) -> str:
    password = f", password: {_q(password_hash)}" if password_hash is not None else ""
    return (
        f"      {{user: {_q(name)}{password}, permissions: {{\n"
        f"        publish: {_rule(perms.publish)}\n"
        f"        subscribe: {_rule(perms.subscribe)}\n"
        "      }}\n"
    )


def nats_config(
    users: BrokerUsers,
    *,
    mqtt_host: str,
    mqtt_port: int,
    store_dir: str,
    shared: bool = True,
    anonymous: bool = False,
    cluster: NatsCluster | None = None,
    server_name: str = "dronefleet",
    http_port: int | None = None,
    nats_port: int | None = None,
    consumer_memory: bool = False,
) -> str:
    """A ``nats-server -c`` configuration: MQTT on ``mqtt_host:mqtt_port`` for ``users``, with
    the rules of messaging/broker_acl.py (``shared`` as there). NATS's own client port, for the
    grounds' shared telemetry ingestion (ground/telemetry/shared_ingest.py), listens on
    ``mqtt_host:nats_port``, for the same users; without ``nats_port``, on loopback only, on a
    port of the system's choosing (unused). ``http_port`` adds the monitoring endpoints, on
    loopback. ``consumer_memory`` keeps the JetStream consumer behind each QoS 1 subscription
    in memory rather than in the store: for a broker whose store outlives nothing (below)."""
    missing = [u.name for u in users.all() if not u.nats_hash]
    if missing:
        raise InvalidInput(
            f"no NATS (bcrypt) password hash kept for {', '.join(missing)}: users made before "
            "it was kept, or whose password is over 72 bytes, must be made again"
        )
    entries = [_user_entry(u.name, u.nats_hash, permissions(u, shared=shared)) for u in users.all()]
    if anonymous:
        everything = Permissions(publish=(">",), subscribe=(">",))
        entries.append(_user_entry(ANONYMOUS_USER, None, everything))
    elif not entries:
        entries.append(_user_entry(LOCKED_USER, LOCKED_HASH, Permissions((), ())))
    name = cluster.server_name if cluster is not None else server_name
    lines = [
        "# Written by dronefleet (messaging/nats_config.py): the rules of messaging/broker_acl.py.",
        f"server_name: {_q(name)}",
    ]
    if nats_port is not None:
        lines.append(f"listen: {_q(f'{mqtt_host}:{nats_port}')}  # NATS clients: shared ingestion")
    else:
        lines.append(
            'listen: "127.0.0.1:-1"  # NATS clients: none; a port of the system\'s choosing'
        )
    if http_port is not None:
        lines.append(f'http: "127.0.0.1:{http_port}"')
    lines += [
        f"max_payload: {MAX_PAYLOAD}",
        f"jetstream {{ store_dir: {_q(store_dir)} }}",
        "accounts {",
        f"  {ACCOUNT} {{",
        "    jetstream: enabled",
        "    users: [",
        *(entry.rstrip("\n") for entry in entries),
        "    ]",
        "  }",
        "}",
        "mqtt {",
        f"  listen: {_q(f'{mqtt_host}:{mqtt_port}')}",
        f"  ack_wait: {_q(ACK_WAIT)}  # NATS's default, 30 s, is long to wait for a lost PUBACK",
    ]
    if anonymous:
        lines.append(f"  no_auth_user: {_q(ANONYMOUS_USER)}")
    if consumer_memory:
        # NATS makes a JetStream consumer for each QoS 1 subscription (a simulated drone has
        # four): 3 to 7 ms of the server's CPU each in the file store, 0.7 in memory (measured
        # beside 300 clients; 1000 drones started took 12 to 28 s of its CPU). The embedded
        # broker's store is a folder made at each start and removed at its stop
        # (messaging/nats_broker.py): a consumer on disk there survives nothing one in memory
        # does not. Messages and sessions stay in the store's streams either way.
        lines.append("  consumer_memory_storage: true")
    if cluster is not None:
        lines.append(f"  stream_replicas: {cluster.stream_replicas}")
    lines.append("}")
    if cluster is not None:
        routes = ", ".join(_q(route) for route in cluster.routes)
        lines += [
            "cluster {",
            f"  name: {_q(cluster.name)}",
            f"  listen: {_q(f'{cluster.host}:{cluster.port}')}",
            f"  routes: [{routes}]",
            "}",
        ]
    return "\n".join(lines) + "\n"
