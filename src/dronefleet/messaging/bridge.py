"""Mosquitto bridge configuration for a drone's Internal Broker (seed 4.3.2, Listing 4.3).

The drone's Mosquitto pulls its own ``control``, ``mission`` and ``gear`` requests from the ground
broker and pushes everything its components publish on ``+/<channel>/out`` to it. Beyond the
listing, the file sets what a bridge to RabbitMQ's MQTT adapter needs (no Mosquitto-private
protocol bit, no ``$SYS`` notifications).

Sessions (issue 13). The bridge's sessions persist on both brokers (``cleansession false``,
``local_cleansession false``), so while the link is down the drone's broker queues for the
ground what must not be lost — progress, alarms, answers: :data:`KEPT_CHANNELS`, bridged at QoS 1
— up to :data:`MAX_QUEUED` messages, and hands them over when the link is back (a ground broker
that was itself restarted gets them too). Telemetry and heartbeats cross at QoS 0: a stale
position or "alive" is worth nothing later, and queued they would fill the queue. Requests to the
drone are pulled at QoS 0 as well, so the ground broker never queues them for the bridge: a
takeoff sent during an outage must not reach the drone a minute later (the ground's request has
timed out and said so); the ground asks again if it still wants it.
"""

from __future__ import annotations

import ipaddress

from dronefleet.messaging.broker_users import hash_password
from dronefleet.messaging.topics import (
    OUT_ONLY,
    Channel,
    Direction,
    any_drone,
    check_drone_id,
    topic,
)

#: Channels the ground sends to the drone (pulled in by the bridge).
IN_CHANNELS = (Channel.CONTROL, Channel.MISSION, Channel.GEAR)
#: Channels the drone sends to the ground (pushed out by the bridge), in the listing's order.
OUT_CHANNELS = (*IN_CHANNELS, *(c for c in Channel if c in OUT_ONLY))
#: Channels the drone's broker keeps for the ground while the link is down (QoS 1).
KEPT_CHANNELS = frozenset({Channel.CONTROL, Channel.MISSION, Channel.GEAR, Channel.ALARMS})
#: Messages the drone's broker queues for the ground while the link is down: a 10,000-step
#: mission's progress (two reports a step) with room to spare; past it Mosquitto drops new ones.
MAX_QUEUED = 50_000


#: The longest a drone's bridge waits between two attempts to reach the ground's broker
#: (Mosquitto's ``restart_timeout`` cap, seconds): after the ground's broker comes back, a drone
#: may be silent this long (the Drone Identifier allows for it: ground/identifier.py).
BRIDGE_RESTART_MAX_S = 10.0


def _quote_free(name: str, value: str) -> str:
    if not value or any(c.isspace() for c in value) or "#" in value:
        raise ValueError(f"{name} must be non-empty, without spaces or '#': {value!r}")
    return value


def bridge_config(
    drone_id: str,
    ground_host: str,
    ground_port: int = 1883,
    *,
    username: str | None = None,
    password: str | None = None,
    connection: str = "groundRelay",
    listener: tuple[str, int] | None = None,
    local_users: tuple[str, str] | None = None,
    qos: int = 1,
    max_queued: int = MAX_QUEUED,
    cafile: str | None = None,
) -> str:
    """The bridge section for ``drone_id`` (a full ``mosquitto.conf`` if ``listener`` is given:
    then ``local_users`` names the password and ACL files :func:`drone_broker_files` wrote, so
    that even on the drone nobody reaches its broker anonymously)."""
    check_drone_id(drone_id)
    if "," in ground_host:
        raise ValueError(
            "a drone's bridge reaches one ground broker: give one node's HOST:PORT, "
            "not a cluster's node list"
        )
    _quote_free("ground host", ground_host)
    _quote_free("connection", connection)
    if not 0 < ground_port < 65536:
        raise ValueError(f"ground port out of range: {ground_port}")
    lines = [f"# dronefleet bridge for drone {drone_id} (seed Listing 4.3)"]
    if listener is not None:
        host, port = listener
        if not ipaddress.ip_address(host if host != "localhost" else "127.0.0.1").is_loopback:
            # The drone's broker is for the drone's own parts; the ground reaches it only
            # through the bridge (issue 12).
            raise ValueError(f"the drone's listener must be on loopback, not {host}")
        if local_users is None:
            raise ValueError("a drone's broker needs its password and ACL files (local_users)")
        passwords, acl = (_quote_free("password file", f) for f in local_users)
        # Request/response is small-packet ping-pong: Nagle would add ~40 ms per hop.
        lines += [
            f"listener {port} {host}",
            "allow_anonymous false",
            f"password_file {passwords}",
            f"acl_file {acl}",
            "set_tcp_nodelay true",
            "",
        ]
    lines += [f"connection {connection}", f"address {ground_host}:{ground_port}"]
    if cafile:  # TLS to the ground: its certificate checked against this CA, and its name
        lines += [f"bridge_cafile {_quote_free('CA file', cafile)}", "bridge_insecure false"]
    if username:
        lines.append(f"username {_quote_free('username', username)}")
    if password:
        lines.append(f"password {_quote_free('password', password)}")
    lines += [
        f"clientid droneMosquitto-{drone_id}",
        "bridge_protocol_version mqttv311",
        "try_private false",
        "notifications false",
        "cleansession false",
        "local_cleansession false",
        "start_type automatic",
        f"restart_timeout 1 {BRIDGE_RESTART_MAX_S:g}",
        "keepalive_interval 10",
        f"max_queued_messages {max_queued}",
    ]
    lines += [f'topic {topic(drone_id, c, Direction.IN)} in 0 "" ""' for c in IN_CHANNELS]
    lines += [
        f'topic {any_drone(c)} out {qos if c in KEPT_CHANNELS else 0} "" ""' for c in OUT_CHANNELS
    ]
    return "\n".join(lines) + "\n"


def drone_broker_files(drone_id: str, password: str) -> tuple[str, str]:
    """(password file, ACL file) for the drone's own Mosquitto: its parts log in as the drone
    (the same user and password as its bridge to the ground) and may use only topics under its
    id. The bridge's own traffic is the broker's and is not checked against the ACL."""
    check_drone_id(drone_id)
    if not password:
        raise ValueError("the drone's broker password is empty")
    passwords = f"{drone_id}:{hash_password(password)}\n"
    acl = (
        "# Written by `dronefleet bridge-config --listener` (messaging/bridge.py): the drone's\n"
        "# parts log in as the drone; anonymous clients are refused.\n"
        f"user {drone_id}\ntopic readwrite {drone_id}/#\n"
    )
    return passwords, acl
