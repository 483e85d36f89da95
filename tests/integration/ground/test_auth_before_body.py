"""Credentials are checked before a body is read, and the failed-login limit is per real client
(issue 25 item 5; ground/manager/hardening.py, auth.py).

- 40 parallel 3.5 MiB bodies with a wrong token against a ``dronefleet ground`` process: each is
  answered 401 (or 429 once the failed-login limit trips) and the process serving them grows by
  less than 50 MB (it grew by ~840 MB when the bodies were parsed before the token was checked).
- ``X-Forwarded-For`` is believed only from a configured trusted proxy: without one, forged
  addresses do not buy fresh budgets; behind one, the forwarded client is the one limited.
"""

from __future__ import annotations

import asyncio
import contextlib
import secrets
import threading
import time
from pathlib import Path

import httpx
import orjson
import pytest

from dronefleet.ground.manager.hardening import MAX_FAILURES
from dronefleet.ground.services import GroundServices
from dronefleet.messaging.embedded import free_port
from support.brokers import mosquitto
from support.ground_procs import ground_cmd, process, wait_http

pytestmark = pytest.mark.integration

PARALLEL = 40
BODY_BYTES = int(3.5 * 1024 * 1024)
GROWTH_LIMIT_MB = 50


def mission_body(size: int) -> bytes:
    """A well-formed mission JSON of about ``size`` bytes: many small steps, the costliest kind
    of body to parse (each step becomes a dict)."""
    step = b'{"command":"sleep","value":1},'
    count = (size - 40) // len(step)
    body = b'{"drones":["QUAD_1"],"steps":[' + step * count
    return body[:-1] + b"]}"


def rss_kb(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError(f"no VmRSS for {pid}")


class PeakRss:
    """The highest RSS of ``pid`` seen while the block runs (sampled every 5 ms)."""

    def __init__(self, pid: int) -> None:
        self.pid, self.peak_kb = pid, 0
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._sample, daemon=True)

    def _sample(self) -> None:
        while not self._done.is_set():
            self.peak_kb = max(self.peak_kb, rss_kb(self.pid))
            time.sleep(0.005)

    def __enter__(self) -> PeakRss:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._done.set()
        self._thread.join()
        self.peak_kb = max(self.peak_kb, rss_kb(self.pid))


async def post_raw(port: int, token: str, body: bytes) -> int:
    """POST ``body`` over a socket of its own and answer the status; the body is written while
    the answer is awaited (the server may answer before it has all of it)."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    head = (
        f"POST /api/v1/missions HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n"
        f"Authorization: Bearer {token}\r\nContent-Type: application/json\r\n"
        f"Content-Length: {len(body)}\r\n\r\n"
    ).encode()

    async def write() -> None:
        with contextlib.suppress(ConnectionError):
            writer.write(head)
            view = memoryview(body)
            for at in range(0, len(body), 64 * 1024):
                writer.write(view[at : at + 64 * 1024])
                await writer.drain()

    sending = asyncio.create_task(write())
    try:
        async with asyncio.timeout(60):
            status_line = await reader.readline()
            await sending
    finally:
        sending.cancel()
        writer.close()
        with contextlib.suppress(ConnectionError):
            await writer.wait_closed()
    return int(status_line.split()[1])


def test_wrong_token_bodies_are_refused_before_they_are_read(tmp_path):
    token = secrets.token_urlsafe(16)
    port = free_port()
    body = mission_body(BODY_BYTES)
    with (
        mosquitto(tmp_path) as broker,
        process(ground_cmd(broker.full(), tmp_path, port, token), tmp_path / "ground.log") as proc,
    ):
        wait_http(f"http://127.0.0.1:{port}", log=tmp_path / "ground.log")
        # The valid token's path is warm (imports, caches) before the figure is taken.
        small = mission_body(10_000)
        assert asyncio.run(post_raw(port, token, small)) in (
            201,
            404,
            422,
        )  # judged, not refused unread
        time.sleep(0.5)
        before = rss_kb(proc.pid)
        with PeakRss(proc.pid) as peak:

            async def flood() -> list[int]:
                wrong = [f"wrong-{i}-{secrets.token_hex(8)}" for i in range(PARALLEL)]
                return await asyncio.gather(*(post_raw(port, t, body) for t in wrong))

            statuses = asyncio.run(flood())
        after = rss_kb(proc.pid)
        grew_mb = (peak.peak_kb - before) / 1024
        print(
            f"ground RSS {before / 1024:.0f} MB before, peak {peak.peak_kb / 1024:.0f} MB, "
            f"{after / 1024:.0f} MB after {PARALLEL} x {BODY_BYTES / 2**20:.1f} MiB wrong-token "
            f"bodies (statuses {sorted(set(statuses))})"
        )
        assert set(statuses) <= {401, 429}, statuses
        assert statuses.count(401) >= 1
        assert grew_mb < GROWTH_LIMIT_MB, f"the ground grew by {grew_mb:.0f} MB"
        # A valid token's body is still read and judged (and a body over the limit still 413).
        assert asyncio.run(post_raw(port, token, small)) in (
            201,
            404,
            422,
        )  # judged, not refused unread
        assert asyncio.run(post_raw(port, token, mission_body(5 * 1024 * 1024))) == 413


async def _statuses(url: str, forwarded: list[str | None], token: str = "guess") -> list[int]:
    out = []
    async with httpx.AsyncClient(base_url=url, timeout=10) as client:
        for i, address in enumerate(forwarded):
            headers = {"Authorization": f"Bearer {token}{i}"}
            if address is not None:
                headers["X-Forwarded-For"] = address
            out.append((await client.get("/api/v1/drones", headers=headers)).status_code)
    return out


async def test_a_forged_forwarded_for_does_not_reset_the_failed_login_limit(ground):
    """No trusted proxy (the default): the header is ignored, the peer is the one limited."""
    forged = [f"203.0.113.{i}" for i in range(MAX_FAILURES + 5)]
    statuses = await _statuses(ground.http_url, forged)
    assert statuses[:MAX_FAILURES] == [401] * MAX_FAILURES
    assert set(statuses[MAX_FAILURES:]) == {429}, statuses


async def test_behind_a_trusted_proxy_the_forwarded_client_is_the_one_limited(broker, tmp_path):
    services = GroundServices(
        broker,
        store_url=f"sqlite:///{tmp_path}/telemetry.db",
        state_path=tmp_path / "ground.db",
        http_port=0,
        trusted_proxies=["127.0.0.1"],
    )
    async with services:
        url = services.http_url
        operator = {"Authorization": f"Bearer {services.operator_token}"}
        async with httpx.AsyncClient(base_url=url, headers=operator, timeout=10) as api:
            assert (await api.get("/api/v1/drones")).status_code == 200  # a token in use
        limited = await _statuses(url, ["198.51.100.7"] * (MAX_FAILURES + 2))
        assert limited[:MAX_FAILURES] == [401] * MAX_FAILURES
        assert set(limited[MAX_FAILURES:]) == {429}, limited
        # Another client behind the same proxy, and the proxy itself, keep their own budgets.
        assert await _statuses(url, ["198.51.100.8", None]) == [401, 401]
        # The proxy appends the address it saw: the client's own claim before it is not believed.
        chained = await _statuses(url, ["198.51.100.9, 198.51.100.7"])
        assert chained == [429]
        async with httpx.AsyncClient(base_url=url, headers=operator, timeout=10) as api:
            r = await api.get("/api/v1/drones", headers={"X-Forwarded-For": "198.51.100.7"})
            assert r.status_code == 200  # a token in use keeps working from a limited client


def test_a_mission_body_is_the_size_it_claims():
    body = mission_body(BODY_BYTES)
    assert abs(len(body) - BODY_BYTES) < 64 and orjson.loads(body)["steps"]
