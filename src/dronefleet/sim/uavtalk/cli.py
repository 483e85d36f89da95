"""Serving simulated vehicles over UAVTalk from the command line.

``python -m dronefleet.sim.uavtalk --uavtalk tcp:127.0.0.1:9000 --count 2 --speedup 20`` (and,
once wired, ``dronefleet sim --uavtalk tcp:127.0.0.1:9000``) runs a SimWorld and serves vehicle
``i`` on port ``9000 + i``. When everything listens it prints one line::

    uavtalk sim ready: UAVTALK_1=tcp:127.0.0.1:9000 UAVTALK_2=tcp:127.0.0.1:9001

``add_arguments`` adds only the options the parser does not have yet, so it can extend a ``sim``
parser that already defines ``--count`` or ``--home``.
"""

from __future__ import annotations

import argparse
import asyncio
from typing import Any

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.protocols.uavtalk.address import parse_tcp_url

DEFAULT_URL = "tcp:127.0.0.1:9000"
DEFAULT_HOME = LLA(40.63, -8.659, 10.0)  # the seed's field at the University of Aveiro


def _lla(text: str) -> LLA:
    try:
        parts = [float(p) for p in text.split(",")]
        return LLA(parts[0], parts[1], parts[2] if len(parts) > 2 else 0.0)
    except (ValueError, IndexError) as exc:
        raise argparse.ArgumentTypeError(f"expected LAT,LON[,ALT]: {exc}") from exc


def _url(text: str) -> str:
    try:
        parse_tcp_url(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from exc
    return text


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options for serving vehicles over UAVTalk (skipping ones the parser already has)."""

    def add(flag: str, **kwargs: Any) -> None:
        if flag not in parser._option_string_actions:  # argparse has no public lookup
            parser.add_argument(flag, **kwargs)

    add(
        "--uavtalk",
        type=_url,
        default=DEFAULT_URL,
        metavar="tcp:HOST:PORT",
        help="serve vehicle i over UAVTalk on PORT+i (default %(default)s)",
    )
    add("--count", type=int, default=1, help="how many vehicles to simulate")
    add("--home", type=_lla, default=DEFAULT_HOME, help="LAT,LON,ALT of the first vehicle")
    add("--spacing-m", type=float, default=5.0, help="homes of further vehicles, metres east")
    add("--speedup", type=float, default=1.0, help="vehicle seconds per wall second")
    add("--battery-pct", type=float, default=100.0, help="initial charge")
    add("--id-prefix", default="UAVTALK", help="vehicle ids are PREFIX_1, PREFIX_2, ...")


async def serve(args: argparse.Namespace, *, ready: asyncio.Event | None = None) -> None:
    """Run the world and the UAVTalk server until cancelled."""
    from dronefleet.sim.uavtalk.server import UAVTalkServer
    from dronefleet.sim.world import SimWorld

    host, port = parse_tcp_url(getattr(args, "uavtalk", None) or DEFAULT_URL)
    count = getattr(args, "count", 1)
    if count < 1:
        raise SystemExit("--count must be at least 1")
    home = getattr(args, "home", DEFAULT_HOME)
    spacing = getattr(args, "spacing_m", 5.0)
    prefix = getattr(args, "id_prefix", "UAVTALK")
    async with SimWorld(speedup=getattr(args, "speedup", 1.0)) as world:
        for i in range(count):
            world.add_vehicle(
                f"{prefix}_{i + 1}",
                ned_to_lla(NED(0.0, i * spacing, 0.0), home),
                initial_charge_pct=getattr(args, "battery_pct", 100.0),
            )
        async with UAVTalkServer(world, host=host, port=port) as server:
            listing = " ".join(f"{vid}={url}" for vid, url in server.endpoints.items())
            print(f"uavtalk sim ready: {listing}", flush=True)
            if ready is not None:
                ready.set()
            await asyncio.Event().wait()
