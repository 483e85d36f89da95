"""InfluxDB telemetry store: the seed's Time Series Database (4.2.2.1), over the v1 HTTP API.

Writes go to ``/write`` in line protocol (measurement ``telemetry``, tag ``drone``, one float field
per telemetry field, microsecond timestamps); queries go to ``/query`` as InfluxQL
``SELECT mean(...) ... GROUP BY time(every) fill(none)``. Debian's ``influxdb`` package (1.6)
serves this API; InfluxDB 2.x and 3.x keep it for compatibility.
"""

from __future__ import annotations

from typing import Any

import httpx

from dronefleet.ground.telemetry.store import (
    MEASUREMENT,
    StoreError,
    TelemetryPoint,
    TelemetryQuery,
    TelemetrySeries,
    round_value,
)


class InfluxTelemetryStore:
    def __init__(
        self,
        *,
        host: str,
        port: int,
        database: str,
        username: str | None = None,
        password: str | None = None,
        url: str | None = None,
        timeout_s: float = 10.0,
    ) -> None:
        self.base = f"http://{host}:{port}"
        self.database = database
        self.url = url or f"influxdb://{host}:{port}/{database}"
        self._auth = {"u": username, "p": password or ""} if username else {}
        self._http = httpx.AsyncClient(base_url=self.base, timeout=timeout_s)

    async def open(self) -> None:
        # CREATE DATABASE is idempotent in InfluxDB 1.x.
        await self._influxql(f'CREATE DATABASE "{self.database}"', post=True, with_db=False)

    async def close(self) -> None:
        await self._http.aclose()

    async def write(self, points: list[TelemetryPoint]) -> int:
        lines = []
        for p in points:
            if not p.fields:
                continue
            body = ",".join(f"{k}={float(v)!r}" for k, v in p.fields.items())
            lines.append(f"{MEASUREMENT},drone={p.drone_id} {body} {p.time_us}")
        if not lines:
            return 0
        params = {"db": self.database, "precision": "u", **self._auth}
        try:
            reply = await self._http.post("/write", params=params, content="\n".join(lines))
        except httpx.HTTPError as exc:
            raise StoreError(f"InfluxDB at {self.base} unreachable: {exc}") from exc
        if reply.status_code != 204:
            raise StoreError(f"InfluxDB refused a write ({reply.status_code}): {reply.text[:300]}")
        return len(lines)

    async def query(self, query: TelemetryQuery) -> TelemetrySeries:
        if query.fields:
            select = ", ".join(f'mean("{f}") AS "{f}"' for f in query.fields)
        else:
            select = "mean(*)"
        q = (
            f'SELECT {select} FROM "{MEASUREMENT}" WHERE "drone" = \'{query.drone_id}\' '
            f"AND time >= {query.from_us}u AND time < {query.to_us}u "
            f"GROUP BY time({query.every_us}u) fill(none)"
        )
        data = await self._influxql(q)
        result = TelemetrySeries(query)
        for statement in data.get("results", []):
            if "error" in statement:
                raise StoreError(f"InfluxDB query failed: {statement['error']}")
            for series in statement.get("series", []):
                columns = series["columns"]
                names = [c.removeprefix("mean_") if not query.fields else c for c in columns]
                for row in series.get("values", []):
                    t = row[0] / 1e6
                    for name, value in zip(names[1:], row[1:], strict=True):
                        if value is not None:
                            result.series.setdefault(name, []).append((t, round_value(value)))
        return result

    async def _influxql(
        self, q: str, *, post: bool = False, with_db: bool = True
    ) -> dict[str, Any]:
        params: dict[str, str] = {"q": q, "epoch": "u", **self._auth}
        if with_db:
            params["db"] = self.database
        try:
            if post:
                reply = await self._http.post("/query", params=params)
            else:
                reply = await self._http.get("/query", params=params)
        except httpx.HTTPError as exc:
            raise StoreError(f"InfluxDB at {self.base} unreachable: {exc}") from exc
        if reply.status_code != 200:
            raise StoreError(f"InfluxDB answered {reply.status_code}: {reply.text[:300]}")
        return reply.json()
