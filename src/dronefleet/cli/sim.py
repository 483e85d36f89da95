"""``dronefleet sim``: serve simulated vehicles to other processes over MAVLink (or UAVTalk).

``dronefleet sim --count 3 --mavlink udp:127.0.0.1:14550`` flies three ArduPilot-Copter-like
vehicles in one sim world; vehicle ``i`` has system id ``i+1`` and listens on port ``14550+i``.
Connect the drone software with ``dronefleet drone --fc mavlink --fc-url udpout:127.0.0.1:14550``
or a ground station (QGroundControl, MAVProxy) to the same ports.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import sys
from pathlib import Path

from dronefleet.cli.args import (
    add_signing_key,
    given_options,
    note_given,
    port_number,
    positive_speedup,
    signing_key,
)
from dronefleet.cli.drone import DEFAULT_HOME, parse_lla, parse_plume
from dronefleet.signals import stop_event


def parse_udp(text: str) -> tuple[str, int]:
    """``udp:HOST:PORT`` (also ``udpin:``) → (host, base port)."""
    scheme, _, rest = text.partition(":")
    host, _, port = rest.rpartition(":")
    if scheme not in ("udp", "udpin") or not host or not port.isdigit():
        raise argparse.ArgumentTypeError(f"expected udp:HOST:PORT, got {text!r}")
    return host, port_number(port)


#: The options only one protocol uses (issue 28, item 6): given with the other, the command
#: refuses them (one line, exit 2) instead of ignoring them. The rest apply to both.
PROTOCOL_OPTIONS: dict[str, tuple[str, str]] = {
    "mavlink": ("mavlink", "the MAVLink ports"),
    "sysid_base": ("mavlink", "MAVLink system ids"),
    "mavlink_signing_key_file": ("mavlink", "MAVLink 2 signing"),
    "plume": (
        "mavlink",
        "the CO2 readings it sends as NAMED_VALUE_FLOAT; over UAVTalk give the drone "
        "dronefleet drone --fc uavtalk --plume",
    ),
    "pictures": ("mavlink", "the camera served over MAVLink"),
    "id_prefix": ("uavtalk", "the vehicles' UAVTalk ids"),
}


EXAMPLES = """examples:
  dronefleet sim --count 3 --mavlink udp:127.0.0.1:14550 --speedup 5
      three vehicles on UDP ports 14550-14552 (dronefleet drone --fc mavlink, or any GCS)
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "sim",
        help="serve simulated vehicles over MAVLink (ArduPilot Copter compatible)",
        epilog=EXAMPLES,
    )
    p.add_argument("--count", type=int, default=1, help="how many vehicles to simulate")
    p.add_argument(
        "--mavlink",
        type=parse_udp,
        default="udp:127.0.0.1:14550",
        help="udp:HOST:PORT of the first vehicle; vehicle i listens on PORT+i",
    )
    p.add_argument("--home", type=parse_lla, default=DEFAULT_HOME, help="LAT,LON,ALT")
    p.add_argument("--spacing-m", type=float, default=15.0, help="distance between homes")
    p.add_argument(
        "--speedup", type=positive_speedup, default=1.0, help="vehicle seconds per wall second"
    )
    p.add_argument("--battery-pct", type=float, default=100.0, help="initial charge")
    p.add_argument(
        "--sysid-base",
        type=_system_id,
        default=1,
        help="MAVLink system id of the first vehicle (vehicle i: BASE+i), so two sims differ",
    )
    p.add_argument(
        "--plume", type=parse_plume, action="append", default=[], help="LAT,LON,PEAK_PPM,RADIUS_M"
    )
    p.add_argument("--pictures", type=Path, help="write each picture taken as a JPEG here")
    add_signing_key(p)
    p.add_argument(
        "--uavtalk",
        metavar="tcp:HOST:PORT",
        help="serve the vehicles over UAVTalk (the seed's protocol) instead; vehicle i on PORT+i",
    )
    from dronefleet.sim.uavtalk.cli import add_arguments as uavtalk_arguments

    uavtalk_arguments(p)  # adds what UAVTalk needs beyond the options above (--id-prefix)
    note_given(p)
    p.set_defaults(func=_run)


def inapplicable(args: argparse.Namespace) -> str | None:
    """Why an option given does not apply to the protocol served (all such, one line), or None."""
    protocol = "uavtalk" if args.uavtalk else "mavlink"
    wrong = [
        f"{option} is for {PROTOCOL_OPTIONS[dest][0]} only ({PROTOCOL_OPTIONS[dest][1]})"
        for dest, option in given_options(args).items()
        if PROTOCOL_OPTIONS.get(dest, (protocol,))[0] != protocol
    ]
    if not wrong:
        return None
    served = "--uavtalk" if args.uavtalk else "MAVLink (no --uavtalk)"
    return f"not when serving {served}: {'; '.join(wrong)}"


def _system_id(text: str) -> int:
    if not text.isdigit() or not 1 <= int(text) <= 250:
        raise argparse.ArgumentTypeError(f"a MAVLink system id is 1-250, not {text!r}")
    return int(text)


def _run(args: argparse.Namespace) -> int:
    from dronefleet.owner_only import private_umask

    private_umask()  # the simulated cameras' pictures: the owner's only (issue 25)
    if args.count < 1:
        print("dronefleet sim: --count must be at least 1", file=sys.stderr)
        return 2
    if getattr(args, "sysid_base", 1) + args.count - 1 > 255:
        print("dronefleet sim: --sysid-base + --count - 1 must be at most 255", file=sys.stderr)
        return 2
    if args.speedup <= 0:
        print("dronefleet sim: --speedup must be positive", file=sys.stderr)
        return 2
    if (why := inapplicable(args)) is not None:
        print(f"dronefleet sim: {why}", file=sys.stderr)
        return 2
    if args.uavtalk:
        from dronefleet.sim.uavtalk.cli import serve as serve_uavtalk

        with contextlib.suppress(KeyboardInterrupt):
            asyncio.run(serve_uavtalk(args))
        return 0
    try:
        args.signing_key = signing_key(args.mavlink_signing_key_file)
    except (OSError, ValueError) as exc:
        print(f"dronefleet sim: the MAVLink signing key: {exc}", file=sys.stderr)
        return 2
    try:
        return asyncio.run(_serve(args))
    except OSError as exc:
        print(f"dronefleet sim: cannot open the MAVLink ports: {exc}", file=sys.stderr)
        return 1


async def _serve(args: argparse.Namespace) -> int:
    from dronefleet.sim.mavlink.server import fleet_server

    host, base_port = args.mavlink
    server = fleet_server(
        args.count,
        home=args.home,
        spacing_m=args.spacing_m,
        speedup=args.speedup,
        host=host,
        base_port=base_port,
        battery_pct=args.battery_pct,
        first_system_id=args.sysid_base,
        plumes=args.plume,
        pictures_dir=args.pictures,
        signing_key=args.signing_key,
    )
    stop = stop_event()
    async with server:
        for ep in server.endpoints:
            home = ep.copter.vehicle.home
            print(
                f"vehicle {ep.system_id} on {ep.url} at {home.lat:.6f},{home.lon:.6f},"
                f"{home.alt_m:g}",
                flush=True,
            )
        print(
            f"sim ready: {args.count} vehicle(s) over MAVLink from udp:{host}:{base_port}"
            f" at {args.speedup:g}x" + (", signed" if args.signing_key else ""),
            flush=True,
        )
        await stop.wait()
    return 0
