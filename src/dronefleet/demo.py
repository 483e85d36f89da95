"""``dronefleet demo``: the whole platform on the embedded default, no system service needed.

An in-process MQTT broker, the ground services (Drone Identifier, Drone Manager with the web UI,
Telemetry Analyzer on SQLite, Mission Planner), and simulated drones placed apart near a home
point. It prints the web UI's URL and the tokens, flies a short demo mission with the first drone
(printing every step as it happens) and keeps serving until Ctrl-C.
"""

from __future__ import annotations

import argparse
import asyncio
import math
import os
import sqlite3
import sys
from pathlib import Path
from typing import Any

from dronefleet import virtual_loop
from dronefleet.cli.args import (
    add_trusted_proxy,
    geocoder_url,
    http_bind_failure,
    tiles_source,
)
from dronefleet.errors import InvalidInput
from dronefleet.geo.types import NED
from dronefleet.signals import stop_event

LEGACY_TOKENS = "demo-tokens.json"  # written by earlier versions, in plaintext

DEMO_SQUARE = [NED(30, 0), NED(30, 30), NED(0, 30), NED(0, 0)]


def parse_hostport(text: str) -> tuple[str, int]:
    host, _, port = text.rpartition(":")
    if not host or not port.isdigit() or int(port) > 65535:
        raise argparse.ArgumentTypeError(f"expected HOST:PORT (port 0-65535), got {text!r}")
    return host, int(port)


EXAMPLES = """examples:
  dronefleet demo
      the web UI at http://127.0.0.1:8080/: open the "sign in" link it prints
  dronefleet demo --http 127.0.0.1:8081 --state-dir /tmp/demo-2
      a second demo beside the first, with its own databases
  dronefleet demo --drones 5 --speedup 10 --recharge-s 30 --no-mission
      five drones, vehicle time 10x the wall clock, batteries swapped after 30 s at home
"""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo",
        help="the platform on the embedded broker with simulated drones",
        description="The broker, the ground services (web UI, REST API) and simulated drones in "
        "one process; prints the web UI's sign-in link and flies a short mission.",
        epilog=EXAMPLES,
    )
    p.add_argument(
        "--http",
        type=parse_hostport,
        default="127.0.0.1:8080",
        metavar="HOST:PORT",
        help="where the web UI and REST API listen (port 0: any free port)",
    )
    p.add_argument(
        "--speedup",
        type=virtual_loop.speedup_arg,
        default=2.0,
        help="vehicle seconds per wall second at most, or 'max' (virtual time: the figures do "
        "not depend on it)",
    )
    p.add_argument("--drones", type=int, default=3, help="simulated drones to start")
    p.add_argument(
        "--state-dir",
        type=Path,
        default="var/demo",
        metavar="DIR",
        help="databases, logs and pictures, made if missing (relative to the current folder)",
    )
    p.add_argument(
        "--tiles",
        type=tiles_source,
        help="map imagery: a tile URL template or a local FILE.mbtiles; none: a plain grid",
    )
    p.add_argument(
        "--geocoder",
        type=geocoder_url,
        help="a Nominatim-compatible geocoder's URL for address search (asked by the ground)",
    )
    p.add_argument(
        "--token",
        help="the operator token to accept (default: a fresh one on the first run, printed once)",
    )
    p.add_argument("--no-mission", action="store_true", help="do not fly the demo mission")
    p.add_argument(
        "--external-drone",
        action="append",
        default=[],
        metavar="ID",
        help="let a drone run apart join (its broker password is written to the state dir); "
        "repeatable",
    )
    p.add_argument("--once", action="store_true", help="exit when the demo mission is done")
    p.add_argument(
        "--recharge-s",
        type=_seconds,
        default=60.0,
        metavar="S",
        help="a drone on the ground at its home, disarmed, for S vehicle seconds gets a full "
        "battery (a swap), so it can fly again or take over; 0: never",
    )
    add_trusted_proxy(p)
    p.set_defaults(func=run)


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds, got {text!r}") from None
    if not 0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be 0 or more seconds, not {text!r}")
    return value


def run(args: argparse.Namespace) -> int:
    if args.drones < 0:
        print("dronefleet demo: --drones must be >= 0", file=sys.stderr)
        return 2
    from dronefleet.owner_only import private_umask

    private_umask()  # databases, logs, pictures: the owner's only (issue 25)
    # Absolute from here on: the telemetry store's URL and every file under it (issue 29: the
    # relative default once made sqlite:///var/demo/..., read as /var/demo).
    args.state_dir = args.state_dir.expanduser().resolve()
    if math.isinf(args.speedup) and args.external_drone:
        print(
            "dronefleet demo: --external-drone needs a broker process, and --speedup max runs on "
            "the in-process bus (a broker process would hold messages the virtual clock cannot "
            "see); choose a finite --speedup",
            file=sys.stderr,
        )
        return 2
    problem = _state_dir_problem(args.state_dir)
    if problem is not None:
        print(f"dronefleet demo: {problem}; choose another with --state-dir DIR", file=sys.stderr)
        return 2
    try:
        # Everything runs in this process, so everything runs on one virtual clock (issue 9).
        return virtual_loop.run(_demo(args), speedup=args.speedup)
    except OSError as exc:
        print(f"dronefleet demo: {exc}", file=sys.stderr)
        return 1
    except InvalidInput as exc:  # e.g. --tiles names a file that is not a raster MBTiles set
        print(f"dronefleet demo: {exc}", file=sys.stderr)
        return 2
    except sqlite3.Error as exc:  # a database in the state folder that SQLite cannot use
        print(f"dronefleet demo: a database in {args.state_dir}: {exc}", file=sys.stderr)
        return 1


def _state_dir_problem(state_dir: Path) -> str | None:
    """Why the demo cannot keep its files in ``state_dir`` (made if missing, 0700), in a few
    words; None when it can."""
    from dronefleet.owner_only import make_dir

    try:
        make_dir(state_dir)
    except OSError as exc:
        return f"cannot make the state folder {state_dir}: {exc.strerror or exc}"
    if not state_dir.is_dir():
        return f"the state folder {state_dir} is not a folder"
    if not os.access(state_dir, os.W_OK | os.X_OK):
        return f"cannot write in the state folder {state_dir}: Permission denied"
    return None


#: Where the demo's CO2 plume is, from home (5,000 ppm at its centre, 15 m wide, at sea level).
DEMO_PLUME = NED(-60.0, -60.0)


def demo_mission(home) -> list[dict[str, Any]]:
    """Arm, take off, fly a 30 m square photographing each corner, hover, land."""
    from dronefleet.geo.ned import ned_to_lla

    steps: list[dict[str, Any]] = [
        {"command": "arm"},
        {"command": "takeoff", "value": 10},
        {"command": "wait_for_flight"},
    ]
    for ned in DEMO_SQUARE:
        corner = ned_to_lla(ned, home)
        steps += [
            {"command": "navigate", "lat": corner.lat, "lon": corner.lon, "altitude_delta": 10},
            {"command": "wait_for_flight"},
            {"command": "takepic"},
        ]
    return [
        *steps,
        {"command": "sleep", "value": 2},
        {"command": "land"},
        {"command": "wait_for_flight"},
    ]


async def _tokens(book: Any, state_dir: Path, given: str | None) -> tuple[str, str] | None:
    """The operator and viewer tokens to print, or None when the last run's are kept.

    Nothing on disk holds a token (issue 12): the ground keeps only their hashes. A first run
    (or ``--token``) makes them and prints them once; a restarted demo keeps accepting the ones
    it printed before (an open page stays signed in) and cannot print them again. An earlier
    version's plaintext ``demo-tokens.json`` is removed.
    """
    from dronefleet.ground.manager.auth import Role, new_token

    (state_dir / LEGACY_TOKENS).unlink(missing_ok=True)
    names = {t["name"] for t in await book.state.list_tokens()}
    if given is None and {"operator", "viewer"} <= names:
        return None
    operator = given or new_token()
    viewer = new_token()
    await book.issue("operator", Role.OPERATOR, operator)
    await book.issue("viewer", Role.VIEWER, viewer)
    return operator, viewer


def _external_drones(broker: Any, names: list[str], state_dir: Path) -> list[str]:
    """Broker users for drones run apart from the demo (``--external-drone``): each password in
    a file only its owner can read; the lines that tell how to start them."""
    from dronefleet.messaging.broker_users import BrokerRole

    folder = state_dir / "drone-secrets"
    folder.mkdir(mode=0o700, exist_ok=True)
    lines = []
    for name in names:
        url = broker.url_for(name, BrokerRole.DRONE)
        secret = folder / f"{name}.secret"
        fd = os.open(secret, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "w") as out:
            out.write(url.password + "\n")
        lines.append(
            f"drone {name} may join: dronefleet drone --id {name} --broker "
            f"mqtt://{name}@{url.host}:{url.port} --broker-password-file {secret}"
        )
    return lines


async def _demo(args: argparse.Namespace) -> int:
    from dronefleet.cli.drone import DEFAULT_HOME, parse_lla
    from dronefleet.drone.config import DroneConfig
    from dronefleet.geo.ned import ned_to_lla
    from dronefleet.ground.manager.auth import TokenBook
    from dronefleet.ground.services import GroundServices
    from dronefleet.ground.telemetry.store import sqlite_url
    from dronefleet.heap import settle_heap
    from dronefleet.messaging.broker_users import BrokerRole
    from dronefleet.messaging.embedded import EmbeddedBroker
    from dronefleet.messaging.local_bus import LocalBus
    from dronefleet.sim.homes import homes_around
    from dronefleet.simfleet import SimFleet

    stop = stop_event()
    home = parse_lla(DEFAULT_HOME)
    state_dir: Path = args.state_dir
    host, port = args.http
    # Every part gets its own broker credentials, in memory only; strangers are refused (the
    # printed broker address carries none: issue 12). The broker is the embedded NATS process,
    # but at --speedup max virtual time would run on while a message is in that process (its
    # answers would come "late"): then the demo runs on the in-process bus, with the same rules.
    broker_kind = LocalBus if math.isinf(args.speedup) else EmbeddedBroker
    async with broker_kind() as broker:
        ground_url = broker.url_for("ground", BrokerRole.GROUND)
        ground = GroundServices(
            ground_url,
            store_url=sqlite_url(state_dir / "telemetry.db"),  # absolute: sqlite:////...
            state_path=state_dir / "ground.db",
            http_host=host,
            http_port=port,
            tiles=args.tiles,
            geocoder=args.geocoder,
            trusted_proxies=args.trusted_proxy,
        )
        try:
            await ground.start()  # stops what it started if it fails
        except OSError as exc:
            line = http_bind_failure(exc, host, port)
            if line is None:
                raise
            print(f"dronefleet demo: {line}", file=sys.stderr)
            return 2
        try:
            assert ground.state is not None  # started above
            tokens = await _tokens(TokenBook(ground.state), state_dir, args.token)
            joining = _external_drones(broker, args.external_drone, state_dir)
            # A CO2 plume south-west of home, away from the demo's square, for the sensors to
            # find: a survey over it reading sensors maps it (planner page, issue 14).
            spot = ned_to_lla(DEMO_PLUME, home)
            async with SimFleet(plumes=[(spot.lat, spot.lon, 5000.0, 15.0)]) as fleet:
                ids = [f"QUAD_{i + 1}" for i in range(args.drones)]
                drones = [
                    (DroneConfig(drone_id=drone_id, log_dir=state_dir / "logs"), url, spot)
                    for drone_id, url, spot in zip(
                        ids,
                        # One reload of the broker's users for them all (NatsBroker.urls_for).
                        broker.urls_for(ids, BrokerRole.DRONE),
                        homes_around(home, args.drones),
                        strict=True,
                    )
                ]
                # Started many at a time: each start waits for the broker's answers.
                await fleet.add_drones(drones, recharge_s=args.recharge_s or None)  # battery swap
                settle_heap()
                print(f"broker: {broker.url}")
                for line in joining:
                    print(line)
                print(f"web UI: {ground.http_url}/")
                print(f"API docs: {ground.http_url}/docs")
                if tokens is None:
                    print(
                        "tokens: kept from the last run (only their hashes are stored): its "
                        "sign-in link still works; --token TOKEN sets a new operator token"
                    )
                else:
                    print(f"operator token: {tokens[0]}")
                    print(f"viewer token: {tokens[1]}")
                    print(f"sign in (open in a browser): {ground.http_url}/?token={tokens[0]}")
                print(
                    f"{len(ids)} simulated drones ({', '.join(ids) or 'none'}); vehicle time runs "
                    f"{args.speedup:g}x at most. Ctrl-C stops everything.",
                    flush=True,
                )
                if ids and not args.no_mission:
                    done = await _fly_demo_mission(ground_url, ids[0], fleet, stop)
                    if args.once:
                        return 0 if done else 1
                await stop.wait()
        finally:
            await ground.stop()
    return 0


async def _fly_demo_mission(broker_url, drone_id: str, fleet, stop: asyncio.Event) -> bool:
    """Send the square mission to ``drone_id`` and print each report until it ends."""
    from dronefleet.messaging import topics
    from dronefleet.messaging.client import BrokerClient
    from dronefleet.messaging.codec import decode_object
    from dronefleet.messaging.missions import MissionRequest, encode_steps_base64
    from dronefleet.messaging.topics import Channel, Direction

    finished = asyncio.Event()
    outcome: dict[str, bool] = {}

    async def show(topic_name: str, payload: bytes) -> None:
        msg = decode_object(payload)
        if msg.get("mission_id") != "demo-square":
            return
        pos = msg.get("position") or {}
        dur = msg.get("step_duration_s")
        line = (
            f"  [{msg.get('vehicle_time_s', 0):7.1f} s] {drone_id} {msg['event']:<9} "
            f"step {msg.get('step_index', '-')!s:>3} {msg.get('command') or '':<16}"
            f"{'' if dur is None else f'{dur:6.1f} s'}  at {pos.get('lat', 0):.6f},"
            f"{pos.get('lon', 0):.6f} {pos.get('relative_alt_m', 0):5.1f} m"
        )
        print(line + (f"  {msg['error']}" if msg.get("error") else ""), flush=True)
        if msg["event"] in {"completed", "failed", "rejected", "stopped"}:
            outcome["ok"] = msg["event"] == "completed"
            finished.set()

    home = fleet.world.vehicles[drone_id].home
    async with BrokerClient(broker_url, "demo-mission") as client:
        await client.subscribe(topics.topic(drone_id, Channel.MISSION, Direction.OUT), show)
        steps = demo_mission(home)
        print(f"sending a {len(steps)}-step demo mission to {drone_id} (base64, as the seed did)")
        await client.publish(
            topics.topic(drone_id, Channel.MISSION, Direction.IN),
            MissionRequest(mission_id="demo-square", mission=encode_steps_base64(steps)),
        )
        waiters = {asyncio.create_task(finished.wait()), asyncio.create_task(stop.wait())}
        _, pending = await asyncio.wait(waiters, return_when=asyncio.FIRST_COMPLETED)
        for task in pending:
            task.cancel()
    return outcome.get("ok", False)
