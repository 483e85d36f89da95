"""The Time Series Database behind the Telemetry Analyzer (seed 4.2.2.1), as one interface.

Two stores answer the same queries the same way: ``sqlite:///path`` (embedded default) and
``influxdb://host:8086/db`` (the seed's InfluxDB, v1 HTTP API). A query asks for one drone's
fields over ``[from, to)`` downsampled to ``every``: buckets aligned to the Unix epoch, the mean of
each field per bucket, empty buckets left out (InfluxDB's ``GROUP BY time(every) fill(none)``).

SQLite URLs follow SQLAlchemy's convention (issue 29): ``sqlite:///var/t.db`` is ``var/t.db``,
relative to the working folder, and four slashes, ``sqlite:////var/t.db``, the absolute
``/var/t.db`` (:func:`sqlite_path`, :func:`sqlite_url`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from os import PathLike, fspath
from typing import Protocol
from urllib.parse import urlsplit

from dronefleet.errors import Unavailable

#: Field names a store accepts (also safe inside InfluxQL double quotes and line protocol).
FIELD_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_.]{0,63}$")
MEASUREMENT = "telemetry"
#: Most buckets one query may ask for.
MAX_BUCKETS = 20_000


@dataclass(frozen=True)
class TelemetryPoint:
    drone_id: str
    time_us: int  # wall time of the sample, microseconds since the Unix epoch
    fields: dict[str, float]


@dataclass(frozen=True)
class TelemetryQuery:
    drone_id: str
    from_us: int
    to_us: int
    every_us: int
    fields: tuple[str, ...] = ()  # empty: every field the drone sent


@dataclass
class TelemetrySeries:
    """The answer: for each field, ``[bucket_start_s, mean]`` pairs in time order."""

    query: TelemetryQuery
    series: dict[str, list[tuple[float, float]]] = field(default_factory=dict)

    def as_json(self) -> dict[str, object]:
        q = self.query
        return {
            "drone": q.drone_id,
            "from": q.from_us / 1e6,
            "to": q.to_us / 1e6,
            "every_s": q.every_us / 1e6,
            "fields": sorted(self.series),
            "series": {k: [[t, v] for t, v in self.series[k]] for k in sorted(self.series)},
        }


class StoreError(Unavailable, RuntimeError):
    """The store could not be reached or refused a request."""


class TelemetryStore(Protocol):
    url: str

    async def open(self) -> None: ...

    async def close(self) -> None: ...

    async def write(self, points: list[TelemetryPoint]) -> int:
        """Store points; return how many were stored."""
        ...

    async def query(self, query: TelemetryQuery) -> TelemetrySeries: ...


def bucket_start_us(time_us: int, every_us: int) -> int:
    return (time_us // every_us) * every_us


def round_value(value: float) -> float:
    """Means from two databases agree to ~1e-12; report 9 significant digits from both."""
    return float(f"{value:.9g}")


def sqlite_path(url: str) -> str:
    """The file a ``sqlite:`` URL names, as SQLAlchemy reads it: what follows ``sqlite:///`` is
    the path, so ``sqlite:///var/t.db`` is relative (``var/t.db``) and ``sqlite:////var/t.db``
    absolute (``/var/t.db``); ``sqlite://``, ``sqlite://:memory:`` and ``sqlite:///:memory:`` are
    an in-memory database. Raises ValueError for a host (``sqlite://host/t.db``)."""
    parts = urlsplit(url)
    if parts.netloc in ("", ":memory:") and parts.path in ("", "/", "/:memory:"):
        return ":memory:"
    if parts.netloc:
        raise ValueError(
            f"telemetry store URL {url!r}: a SQLite file has no host; use sqlite:///relative/path "
            "or sqlite:////absolute/path"
        )
    # Drop the one slash between "sqlite://" and the path; an absolute path keeps its own.
    return parts.path[1:]


def sqlite_url(path: str | PathLike[str]) -> str:
    """The ``sqlite:`` URL of ``path``: ``sqlite:////abs/t.db`` for an absolute path."""
    return f"sqlite:///{fspath(path)}"


def open_store(url: str) -> TelemetryStore:
    """A store for ``sqlite:///path`` (:func:`sqlite_path`), ``sqlite://:memory:`` or
    ``influxdb://host:port/db``."""
    parts = urlsplit(url)
    if parts.scheme == "sqlite":
        from dronefleet.ground.telemetry.sqlite_store import SqliteTelemetryStore

        return SqliteTelemetryStore(sqlite_path(url), url=url)
    if parts.scheme in {"influxdb", "influx"}:
        from dronefleet.ground.telemetry.influx_store import InfluxTelemetryStore

        database = parts.path.strip("/") or "dronefleet"
        return InfluxTelemetryStore(
            host=parts.hostname or "127.0.0.1",
            port=parts.port or 8086,
            database=database,
            username=parts.username,
            password=parts.password,
            url=url,
        )
    raise ValueError(
        f"telemetry store URL {url!r}: use sqlite:///relative/path, sqlite:////absolute/path or "
        "influxdb://host:port/db"
    )
