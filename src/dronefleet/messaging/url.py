"""Broker URLs choose the broker (docs/DESIGN.md §3): ``mqtt://user:pass@host:port``, or over
TLS ``mqtts://user@host:8883?cafile=/path/ca.pem`` (the broker's certificate checked against that
CA, or the system's CAs without one; issue 12), with ``&certfile=…&keyfile=…`` for a broker that
asks clients for a certificate (Mosquitto's ``require_certificate``). ``local://user:pass@bus-…``
names an in-process bus (messaging/local_bus.py) of the simulations on virtual time."""

from __future__ import annotations

from dataclasses import dataclass
from urllib.parse import parse_qs, quote, unquote, urlsplit

_TLS = {"mqtts", "ssl"}
#: URL query option -> field; all of them TLS files.
_OPTIONS = {"cafile": "ca_file", "certfile": "cert_file", "keyfile": "key_file"}


@dataclass(frozen=True)
class BrokerUrl:
    host: str
    port: int = 1883
    username: str | None = None
    password: str | None = None
    tls: bool = False
    ca_file: str | None = None  # the CA that signed the broker's certificate (TLS)
    cert_file: str | None = None  # the client's own certificate (TLS, when the broker asks)
    key_file: str | None = None  # its private key (else in cert_file)
    local: bool = False  # an in-process bus (messaging/local_bus.py): ``host`` is its name

    @classmethod
    def parse(cls, url: str) -> BrokerUrl:
        parts = urlsplit(url if "://" in url else f"mqtt://{url}")
        if parts.scheme not in {"mqtt", "tcp", "local", *_TLS}:
            raise ValueError(f"broker URL {url!r}: scheme must be mqtt:// or mqtts://")
        local = parts.scheme == "local"
        if not parts.hostname:
            raise ValueError(f"broker URL {url!r} has no host")
        tls = parts.scheme in _TLS
        try:
            port = parts.port or (8883 if tls else 1883)
        except ValueError as exc:
            raise ValueError(f"broker URL {url!r} has an invalid port") from exc
        query = parse_qs(parts.query)
        if local:
            if query or parts.port:
                raise ValueError(f"broker URL {url!r}: an in-process bus has no port or options")
            return cls(
                host=parts.hostname,
                port=0,
                username=unquote(parts.username) if parts.username else None,
                password=unquote(parts.password) if parts.password else None,
                local=True,
            )
        if set(query) - set(_OPTIONS) or (query and not tls):
            raise ValueError(
                f"broker URL {url!r}: the only options are cafile, certfile and keyfile, "
                "with mqtts://"
            )
        if "keyfile" in query and "certfile" not in query:
            raise ValueError(f"broker URL {url!r}: keyfile= needs certfile=")
        return cls(
            host=parts.hostname,
            port=port,
            username=unquote(parts.username) if parts.username else None,
            password=unquote(parts.password) if parts.password else None,
            tls=tls,
            ca_file=query["cafile"][-1] if "cafile" in query else None,
            cert_file=query["certfile"][-1] if "certfile" in query else None,
            key_file=query["keyfile"][-1] if "keyfile" in query else None,
        )

    def _tail(self) -> str:
        options = [
            f"{key}={quote(value, safe='/')}"
            for key, field in _OPTIONS.items()
            if (value := getattr(self, field)) is not None
        ]
        if self.local:
            return self.host
        return f"{self.host}:{self.port}" + ("?" + "&".join(options) if options else "")

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
