"""``dronefleet ground`` (all ground services) and ``dronefleet bridge-config`` (Listing 4.3)."""

from __future__ import annotations

import argparse
import asyncio
import sys
from collections.abc import Callable
from pathlib import Path

from dronefleet.cli.args import (
    add_broker_password,
    add_trusted_proxy,
    broker_url,
    broker_with_password,
    geocoder_url,
    http_bind_failure,
    port_number,
    positive_speedup,
    store_url,
    tiles_source,
)
from dronefleet.cli.broker_files import (
    add_owner_argument,
    broker_owner,
    check_reachable,
    make_folder,
    secret_file,
)
from dronefleet.signals import stop_event


def state_spec(text: str) -> str | Path:
    """``--state``: a PostgreSQL URL as given, anything else a file."""
    return text if text.startswith(("postgresql://", "postgres://")) else Path(text)


def nats_address(option: str) -> Callable[[str], str]:
    """``option``'s type (``--share-ingestion``, ``--fleet-over-nats``):
    ``nats://HOST:PORT[,HOST:PORT...]``, checked and passed on as given; the reason names it."""

    def checked(text: str) -> str:
        from dronefleet.errors import InvalidInput
        from dronefleet.messaging.nats_link import nats_servers

        try:
            nats_servers(text, option)
        except InvalidInput as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        return text

    return checked


def _host_port(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit():
        raise argparse.ArgumentTypeError(f"expected HOST:PORT, got {text!r}")
    return host, port_number(port) if port != "0" else 0


GROUND_EXAMPLES = """examples:
  dronefleet ground --broker mqtt://ground@127.0.0.1:1883 --broker-password-file ground.secret \\
      --state var/ground.db --store sqlite:///var/telemetry.db --http 0.0.0.0:8080
      (sqlite:///var/telemetry.db is var/telemetry.db here; sqlite:////var/telemetry.db is
      /var/telemetry.db)
"""
BRIDGE_EXAMPLES = """examples:
  dronefleet bridge-config --drone-id QUAD_1 --ground ground-host:1883 \\
      --username QUAD_1 --password-file QUAD_1.secret > bridge.conf
"""


def register(sub: argparse._SubParsersAction) -> None:
    g = sub.add_parser(
        "ground",
        help="run the ground services (identifier, manager, telemetry)",
        epilog=GROUND_EXAMPLES,
    )
    g.add_argument(
        "--broker", type=broker_url, default="mqtt://127.0.0.1:1883", help="ground broker URL"
    )
    add_broker_password(g)
    g.add_argument(
        "--store",
        type=store_url,
        default="sqlite:///dronefleet-telemetry.db",
        help="telemetry store: sqlite:///RELATIVE/PATH (to the current folder), "
        "sqlite:////ABSOLUTE/PATH (four slashes, as SQLAlchemy) or influxdb://HOST:PORT/DB",
    )
    g.add_argument(
        "--state",
        type=state_spec,
        default="dronefleet-ground.db",
        help="the ground's state: an SQLite file, or postgresql://USER@HOST:PORT/DB shared by "
        "several ground replicas (docs/deployment.md)",
    )
    g.add_argument(
        "--http",
        type=_host_port,
        default="127.0.0.1:8080",
        metavar="HOST:PORT",
        help="where the web UI and REST API listen (port 0: any free port)",
    )
    g.add_argument("--token", help="operator API token to accept (default: one is made)")
    g.add_argument(
        "--admin-token", help="admin API token to accept (default: one is made on the first start)"
    )
    g.add_argument("--command-timeout", type=float, default=30.0, help="seconds per command")
    g.add_argument(
        "--planning-budget",
        type=positive_speedup,  # a positive, finite number of seconds
        default=10.0,
        help="CPU seconds a mission may take to plan (then 422 'too complex')",
    )
    g.add_argument(
        "--lost-after",
        type=positive_speedup,  # a positive, finite number of seconds
        default=2.0,
        help="seconds at least without a heartbeat, counted in the ground's own awake time (not "
        "while it was stalled or its broker link down), before a drone is lost: 3 of the drone's "
        "declared heartbeat intervals, never less than this; its work is taken over only after "
        "as long again, and not if it is heard before the replacement starts",
    )
    g.add_argument(
        "--tiles",
        type=tiles_source,
        help="map imagery for the web maps: a tile URL template or a local FILE.mbtiles "
        "(none: a plain grid)",
    )
    g.add_argument(
        "--geocoder",
        type=geocoder_url,
        help="a Nominatim-compatible geocoder's URL for address search on the maps "
        "(asked by the ground, never by the pages)",
    )
    g.add_argument(
        "--photo-dir",
        type=Path,
        help="where the drones' pictures are kept per mission (default: photos/ beside --state)",
    )
    g.add_argument(
        "--share-ingestion",
        type=nats_address("--share-ingestion"),
        metavar="NATS_URL",
        help="store only this replica's share of the fleet's telemetry, taken in a NATS queue "
        "group at NATS_URL (nats://HOST:4222[,HOST:PORT...]: the client port of the NATS server "
        "or cluster whose MQTT listener --broker is, logged in as the --broker user), so each "
        "message is stored by one replica; a broker that is not NATS is refused "
        "(docs/deployment.md); default: store all of it",
    )
    g.add_argument(
        "--partition-fleet",
        action="store_true",
        help="share the fleet by drone with the other replicas on the same --state "
        "postgresql://...: this replica takes (stores, streams, checks) only its own drones' "
        "telemetry and sees the others' from their replicas' pictures (docs/deployment.md); "
        "refused with an SQLite state or with --share-ingestion",
    )
    g.add_argument(
        "--fleet-over-nats",
        type=nats_address("--fleet-over-nats"),
        metavar="NATS_URL",
        help="read the fleet's telemetry and heartbeats at NATS_URL (nats://HOST:4222[,...]: "
        "the client port of the NATS server or cluster whose MQTT listener --broker is, logged "
        "in as the --broker user) over NATS's own protocol, at about a third of MQTT's CPU a "
        "message; a broker that is not NATS is refused (docs/deployment.md); default: over "
        "--broker",
    )
    add_trusted_proxy(g)
    g.set_defaults(func=run_ground)

    b = sub.add_parser(
        "bridge-config",
        help="print a drone's Mosquitto bridge config (Listing 4.3)",
        epilog=BRIDGE_EXAMPLES,
    )
    b.add_argument("--drone-id", required=True, help="the drone whose broker is bridged")
    b.add_argument("--ground", type=_host_port, required=True, help="ground broker HOST:PORT")
    b.add_argument("--username", help="the drone's broker user (dronefleet credentials add-drone)")
    b.add_argument("--password-file", type=Path, help="file holding its password")
    b.add_argument("--connection", default="groundRelay", help="bridge connection name")
    b.add_argument(
        "--cafile", type=Path, help="TLS to the ground broker: the CA that signed its certificate"
    )
    b.add_argument(
        "--listener",
        type=_host_port,
        help="also write the drone broker's loopback listener (a whole config); needs --local-dir",
    )
    b.add_argument(
        "--local-dir",
        type=Path,
        help="with --listener: write the drone broker's password and ACL files here (0600); "
        "the drone's parts log in as --username with the password of --password-file",
    )
    add_owner_argument(b)
    b.set_defaults(func=run_bridge_config)


def _drone_broker_users(args: argparse.Namespace) -> tuple[str, str] | None:
    """With ``--listener``: the drone broker's password and ACL files, written (0600)."""
    from dronefleet.messaging.bridge import drone_broker_files

    if args.listener is None:
        return None
    if args.local_dir is None or args.password_file is None:
        raise ValueError("--listener needs --local-dir and --password-file (no anonymous access)")
    if args.username not in (None, args.drone_id):
        raise ValueError("on the drone's own broker the user is the drone: --username DRONE_ID")
    passwords, acl = drone_broker_files(args.drone_id, args.password_file.read_text().strip())
    local_dir = args.local_dir.resolve()
    owner = broker_owner(args.owner)  # Mosquitto reads them as its own user (cli/broker_files.py)
    check_reachable(local_dir, owner)
    make_folder(local_dir)
    paths = (local_dir / "passwords", local_dir / "acl")
    for path, text in zip(paths, (passwords, acl), strict=True):
        secret_file(path, text, owner)
    return str(paths[0]), str(paths[1])


def run_bridge_config(args: argparse.Namespace) -> int:
    from dronefleet.messaging.bridge import bridge_config

    try:
        local_users = _drone_broker_users(args)
        text = bridge_config(
            args.drone_id,
            args.ground[0],
            args.ground[1],
            username=args.username,
            password=args.password_file.read_text().strip() if args.password_file else None,
            connection=args.connection,
            listener=args.listener,
            local_users=local_users,
            cafile=str(args.cafile.resolve()) if args.cafile else None,
        )
    except (OSError, ValueError) as exc:
        print(f"dronefleet bridge-config: {exc}", file=sys.stderr)
        return 2
    sys.stdout.write(text)
    return 0


def run_ground(args: argparse.Namespace) -> int:
    from dronefleet.owner_only import private_umask

    private_umask()  # databases (and their -wal/-shm), photos: the owner's only (issue 25)
    try:
        args.broker = broker_with_password(args.broker, args.broker_password_file)
    except (OSError, ValueError) as exc:
        print(f"dronefleet ground: {exc}", file=sys.stderr)
        return 2
    return asyncio.run(_ground(args))


async def _ground(args: argparse.Namespace) -> int:
    from dronefleet.errors import InvalidInput, Unavailable
    from dronefleet.ground.presence import GroundAlreadyRunning
    from dronefleet.ground.services import GroundServices
    from dronefleet.heap import settle_heap
    from dronefleet.messaging.client import BrokerUnavailable

    services = GroundServices(
        args.broker,
        store_url=args.store,
        state_path=args.state,
        http_host=args.http[0],
        http_port=args.http[1],
        token=args.token,
        admin_token=args.admin_token,
        command_timeout_s=args.command_timeout,
        planning_budget_s=args.planning_budget,
        lost_after_s=args.lost_after,
        tiles=args.tiles,
        geocoder=args.geocoder,
        photo_dir=args.photo_dir,
        trusted_proxies=args.trusted_proxy,
        share_ingestion=args.share_ingestion,
        partition_fleet=args.partition_fleet,
        fleet_over_nats=args.fleet_over_nats,
    )
    try:
        await services.start()
    except (
        GroundAlreadyRunning, BrokerUnavailable, OSError, ValueError, InvalidInput, Unavailable
    ) as exc:  # fmt: skip
        bind = http_bind_failure(exc, *args.http) if isinstance(exc, OSError) else None
        reason = bind or (exc.strerror if isinstance(exc, OSError) and exc.strerror else exc)
        print(f"dronefleet ground: {reason}", file=sys.stderr)
        return 2
    settle_heap()  # a long-running stream handler (dronefleet/heap.py)
    print(
        f"ground services on {services.http_url} (API docs: {services.http_url}/docs)", flush=True
    )
    if services.operator_token:
        print(f"operator token: {services.operator_token}", flush=True)
    if services.admin_token and not args.admin_token:
        print(f"admin token: {services.admin_token}", flush=True)
    if not services.operator_token:
        print("tokens kept from the state store (pass --token to set one)", flush=True)
    stop = stop_event()
    await stop.wait()
    await services.stop()
    return 0
