"""Broker URLs: ``mqtt://user:pass@host:port`` chooses the broker (docs/DESIGN.md §3)."""

from __future__ import annotations

from dataclasses import dataclass
from urllib.parse import quote, unquote, urlsplit


@dataclass(frozen=True)
class BrokerUrl:
    host: str
    port: int = 1883
    username: str | None = None
    password: str | None = None

    @classmethod
    def parse(cls, url: str) -> BrokerUrl:
        parts = urlsplit(url if "://" in url else f"mqtt://{url}")
        if parts.scheme not in {"mqtt", "tcp"}:
            raise ValueError(f"broker URL {url!r}: scheme must be mqtt://")
        if not parts.hostname:
            raise ValueError(f"broker URL {url!r} has no host")
        try:
            port = parts.port or 1883
        except ValueError as exc:
            raise ValueError(f"broker URL {url!r} has an invalid port") from exc
        return cls(
            host=parts.hostname,
            port=port,
            username=unquote(parts.username) if parts.username else None,
            password=unquote(parts.password) if parts.password else None,
        )

    def __str__(self) -> str:
        auth = f"{self.username}:***@" if self.username else ""
        return f"mqtt://{auth}{self.host}:{self.port}"

    def full(self) -> str:
        """The URL with its password, for handing to a child process."""
        auth = ""
        if self.username:
            secret = f":{quote(self.password, safe='')}" if self.password else ""
            auth = quote(self.username, safe="") + secret + "@"
        return f"mqtt://{auth}{self.host}:{self.port}"
