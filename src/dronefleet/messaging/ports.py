"""Free ports for servers the project starts itself (brokers, ground services, simulators)."""

from __future__ import annotations

import random
import socket

#: Ports :func:`free_port` draws from: below Linux's ephemeral range (32768-60999 by default,
#: /proc/sys/net/ipv4/ip_local_port_range), which the system hands out for ``bind(host, 0)`` and
#: outgoing connections.
PORTS = range(20_000, 32_768)


def free_port(host: str = "127.0.0.1", kind: int = socket.SOCK_STREAM) -> int:
    """A TCP (or, with ``kind=socket.SOCK_DGRAM``, UDP) port nobody is bound to now, for a
    server to bind soon after.

    Drawn at random from :data:`PORTS` and tried, rather than asked of the system with port 0:
    the system gives a port just released to the next ``bind(0)``, so with two processes
    (pytest-xdist workers) each finding a port, one's "free" port was the other's next one, and a
    server bound a moment later failed with "Address already in use"."""
    draw = random.Random()  # its own generator: a test seeding ``random`` must not repeat ports
    for _ in range(100):
        port = draw.choice(PORTS)
        with socket.socket(socket.AF_INET, kind) as sock:
            try:
                sock.bind((host, port))
            except OSError:
                continue
            return port
    with socket.socket(socket.AF_INET, kind) as sock:
        sock.bind((host, 0))
        return int(sock.getsockname()[1])
