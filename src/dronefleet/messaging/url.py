"""Broker URLs choose the broker (docs/DESIGN.md §3): ``mqtt://user:pass@host:port``, or over
TLS ``mqtts://user@host:8883?cafile=/path/ca.pem`` (the broker's certificate checked against that
CA, or the system's CAs without one; issue 12), with ``&certfile=…&keyfile=…`` for a broker that
asks clients for a certificate (Mosquitto's ``require_certificate``). ``local://user:pass@bus-…``
names an in-process bus (messaging/local_bus.py) of the simulations on virtual time.

A broker cluster is named by its nodes, comma-separated, with one user, password and set of TLS
options for them all: ``mqtt://user:pass@10.0.0.1:1883,10.0.0.2:1883,10.0.0.3`` (issue 27); a
client goes to the first and fails over to the others in turn (messaging/connection.py)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple
from urllib.parse import parse_qs, quote, unquote, urlsplit

_TLS = {"mqtts", "ssl"}
#: URL query option -> field; all of them TLS files.
_OPTIONS = {"cafile": "ca_file", "certfile": "cert_file", "keyfile": "key_file"}


class BrokerNode(NamedTuple):
    """One node of a broker (a cluster has several)."""

    host: str
    port: int

    def __str__(self) -> str:
        return f"[{self.host}]:{self.port}" if ":" in self.host else f"{self.host}:{self.port}"


@dataclass(frozen=True)
class BrokerUrl:
    host: str  # the first node's (a cluster's other nodes in ``more_nodes``)
    port: int = 1883
    username: str | None = None
    password: str | None = None
    tls: bool = False
    ca_file: str | None = None  # the CA that signed the broker's certificate (TLS)
    cert_file: str | None = None  # the client's own certificate (TLS, when the broker asks)
    key_file: str | None = None  # its private key (else in cert_file)
    local: bool = False  # an in-process bus (messaging/local_bus.py): ``host`` is its name
    more_nodes: tuple[BrokerNode, ...] = ()  # a cluster's nodes after the first

    def __post_init__(self) -> None:
        if self.local and self.more_nodes:
            raise ValueError("an in-process bus (local://) is one bus: it has no other nodes")
        if len(set(self.nodes)) != len(self.nodes):
            raise ValueError(f"broker URL {self}: a node is named twice")

    @property
    def nodes(self) -> tuple[BrokerNode, ...]:
        """Every node, the first (``host``, ``port``) first."""
        return (BrokerNode(self.host, self.port), *self.more_nodes)

    @classmethod
    def parse(cls, url: str) -> BrokerUrl:
        parts = urlsplit(url if "://" in url else f"mqtt://{url}")
        if parts.scheme not in {"mqtt", "tcp", "local", *_TLS}:
            raise ValueError(f"broker URL {url!r}: scheme must be mqtt:// or mqtts://")
        if "://" in url.partition("://")[2]:
            raise ValueError(
                f"broker URL {url!r}: one scheme for all nodes, written once "
                "(mqtt://user:pass@host1:port1,host2:port2); a cluster's nodes cannot mix "
                "mqtt:// and mqtts://"
            )
        local = parts.scheme == "local"
        tls = parts.scheme in _TLS
        userinfo, at, hosts = parts.netloc.rpartition("@")
        if at and "," in userinfo:
            raise ValueError(
                f"broker URL {url!r}: one user and password for all nodes, written once before "
                "the first (mqtt://user:pass@host1:port1,host2:port2); a ',' in a password "
                "is written %2C"
            )
        if not hosts:
            raise ValueError(f"broker URL {url!r} has no host")
        nodes = [_node(url, text, tls) for text in hosts.split(",")]
        username = unquote(parts.username) if parts.username else None
        password = unquote(parts.password) if parts.password else None
        query = parse_qs(parts.query)
        if local:
            if len(nodes) > 1:
                raise ValueError(f"broker URL {url!r}: an in-process bus has one name, no nodes")
            if query or urlsplit(f"//{hosts}").port:
                raise ValueError(f"broker URL {url!r}: an in-process bus has no port or options")
            return cls(nodes[0].host, 0, username, password, local=True)
        if set(query) - set(_OPTIONS) or (query and not tls):
            raise ValueError(
                f"broker URL {url!r}: the only options are cafile, certfile and keyfile, "
                "with mqtts://"
            )
        if "," in parts.query:
            raise ValueError(
                f"broker URL {url!r}: TLS options are for all nodes, written once after the "
                "last (mqtts://host1:port1,host2:port2?cafile=...); a ',' in a file name is "
                "written %2C"
            )
        if "keyfile" in query and "certfile" not in query:
            raise ValueError(f"broker URL {url!r}: keyfile= needs certfile=")
        return cls(
            host=nodes[0].host,
            port=nodes[0].port,
            username=username,
            password=password,
            tls=tls,
            ca_file=query["cafile"][-1] if "cafile" in query else None,
            cert_file=query["certfile"][-1] if "certfile" in query else None,
            key_file=query["keyfile"][-1] if "keyfile" in query else None,
            more_nodes=tuple(nodes[1:]),
        )

    def _tail(self) -> str:
        options = [
            f"{key}={quote(value, safe='/')}"
            for key, field in _OPTIONS.items()
            if (value := getattr(self, field)) is not None
        ]
        if self.local:
            return self.host
        nodes = ",".join(str(node) for node in self.nodes)
        return nodes + ("?" + "&".join(options) if options else "")

    @property
    def scheme(self) -> str:
        return "local" if self.local else "mqtts" if self.tls else "mqtt"

    def __str__(self) -> str:
        """The URL without its password; the user name quoted as in :meth:`full` (a RabbitMQ
        ``vhost:user`` is ``vhost%3Auser``), so what is shown can be used again."""
        auth = f"{quote(self.username, safe='')}:***@" if self.username else ""
        return f"{self.scheme}://{auth}{self._tail()}"

    def full(self) -> str:
        """The URL with its password, for handing to a child process."""
        auth = ""
        if self.username:
            secret = f":{quote(self.password, safe='')}" if self.password else ""
            auth = quote(self.username, safe="") + secret + "@"
        return f"{self.scheme}://{auth}{self._tail()}"


def _node(url: str, text: str, tls: bool) -> BrokerNode:
    """One ``host[:port]`` of ``url``'s node list (the port by default 8883 over TLS, else 1883)."""
    if not text:
        raise ValueError(f"broker URL {url!r} has an empty node (a ',' too many)")
    parts = urlsplit(f"//{text}")
    if not parts.hostname:
        raise ValueError(f"broker URL {url!r} has no host" + (f" in {text!r}" if text else ""))
    try:
        port = parts.port or (8883 if tls else 1883)
    except ValueError as exc:
        raise ValueError(f"broker URL {url!r} has an invalid port in {text!r}") from exc
    return BrokerNode(parts.hostname, port)
