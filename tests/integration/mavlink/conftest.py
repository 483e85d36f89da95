"""Shared pieces for the MAVLink tests: free UDP ports and a simulated fleet served over MAVLink."""

from __future__ import annotations

import contextlib
import random
import socket

import pytest

from dronefleet.geo.types import LLA
from dronefleet.sim.mavlink import fleet_server

HOME = LLA(40.63, -8.659, 10.0)


def free_udp_ports(count: int) -> int:
    """A base port with ``count`` consecutive free loopback UDP ports after it."""
    for _ in range(200):
        base = random.randint(20000, 60000 - count)
        sockets = []
        try:
            for port in range(base, base + count):
                s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                sockets.append(s)
                s.bind(("127.0.0.1", port))
            return base
        except OSError:
            continue
        finally:
            for s in sockets:
                with contextlib.suppress(OSError):
                    s.close()
    raise RuntimeError("no free UDP ports")


@pytest.fixture
async def sim_fleet():
    """``async with sim_fleet(count, speedup=…) as server`` over free UDP ports."""
    servers = []

    @contextlib.asynccontextmanager
    async def make(count: int = 1, *, speedup: float = 20.0, **options):
        server = fleet_server(
            count, home=HOME, speedup=speedup, base_port=free_udp_ports(count), **options
        )
        servers.append(server)
        async with server:
            yield server

    yield make
