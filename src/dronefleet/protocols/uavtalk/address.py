"""UAVTalk endpoint addresses, ``tcp:HOST:PORT``, as the drone's ``--fc-url`` and the simulator's
``--uavtalk`` take them."""

from __future__ import annotations


def parse_tcp_url(url: str) -> tuple[str, int]:
    """``tcp:HOST:PORT`` (or ``tcp://HOST:PORT``) -> (host, port)."""
    rest = url.removeprefix("tcp://").removeprefix("tcp:")
    host, sep, port = rest.rpartition(":")
    if not sep or not host or not port.isdigit() or rest == url:
        raise ValueError(f"expected a UAVTalk URL like tcp:127.0.0.1:9000, got {url!r}")
    return host, int(port)
