"""``GET /api/v1/health`` tells the truth (issue 26, item 7).

Measured before: always ``200 {"ok": true}`` (manager/app.py), even with a full disk under the
ground's state. Now each problem makes it ``503 {"status": "degraded", "problems": [...]}`` with
the reason, and its end makes it ``200 ok`` again: the broker stopped and started again on its
port; a full disk (the free-space probe faked, and a real 4 MB tmpfs filled up when the test may
mount one); a telemetry store that fails its writes; a planner task that dies.
"""

from __future__ import annotations

import asyncio
import contextlib
import sqlite3
import subprocess
from collections.abc import AsyncIterator, Callable
from pathlib import Path
from typing import Any

import httpx
import pytest

from dronefleet.ground.manager import health
from dronefleet.ground.services import GroundServices
from dronefleet.messaging.embedded import free_port
from support.brokers import Mosquitto
from support.ground_fakes import FakeDrone

pytestmark = pytest.mark.integration


@contextlib.asynccontextmanager
async def ground_on(
    broker: Any, state_dir: Path
) -> AsyncIterator[tuple[GroundServices, httpx.AsyncClient]]:
    services = GroundServices(
        broker,
        store_url=f"sqlite:///{state_dir}/telemetry.db",
        state_path=state_dir / "ground.db",
        serve_http=False,
        planner_client_id=f"health-{free_port()}",
    )
    async with services:
        transport = httpx.ASGITransport(app=services.app)
        async with httpx.AsyncClient(transport=transport, base_url="http://ground") as api:
            yield services, api


async def answer(api: httpx.AsyncClient) -> tuple[int, dict[str, Any]]:
    r = await api.get("/api/v1/health")  # open, as a load balancer's probe is
    return r.status_code, r.json()


async def until(
    api: httpx.AsyncClient, wanted: Callable[[int, dict[str, Any]], bool], timeout_s: float = 20
) -> dict[str, Any]:
    status, body = await answer(api)
    async with asyncio.timeout(timeout_s):
        while not wanted(status, body):
            await asyncio.sleep(0.1)
            status, body = await answer(api)
    return body


def degraded_by(what: str) -> Callable[[int, dict[str, Any]], bool]:
    return lambda status, body: status == 503 and what in {p["what"] for p in body["problems"]}


def ok(status: int, body: dict[str, Any]) -> bool:
    return status == 200 and body["status"] == "ok"


def detail(body: dict[str, Any], what: str) -> str:
    return next(p["detail"] for p in body["problems"] if p["what"] == what)


@pytest.fixture
def state_dir(tmp_path: Path) -> Path:
    path = tmp_path / "state"
    path.mkdir()
    return path


async def test_ok_then_503_broker_while_the_broker_is_away_then_ok(tmp_path, state_dir):
    broker = Mosquitto(tmp_path)
    url = broker.start()
    try:
        async with ground_on(url, state_dir) as (_, api):
            status, body = await answer(api)
            assert (status, body["status"], body["ok"], body["problems"]) == (200, "ok", True, [])
            assert "dropped_messages" in body and body["version"]

            broker.stop()
            body = await until(api, degraded_by("broker"))
            assert body["status"] == "degraded" and body["ok"] is False
            why = detail(body, "broker")
            assert why.startswith("not connected to the broker: ") and "planner" in why, why

            broker.start()  # again, on its port
            await until(api, ok, timeout_s=30)  # every service reconnected by itself
    finally:
        broker.stop()


@pytest.fixture
async def ground(tmp_path, state_dir) -> AsyncIterator[tuple[GroundServices, httpx.AsyncClient]]:
    broker = Mosquitto(tmp_path)
    url = broker.start()
    try:
        async with ground_on(url, state_dir) as pair:
            await until(pair[1], ok)
            yield pair
    finally:
        broker.stop()


async def test_a_nearly_full_disk_is_503_until_there_is_room_again(ground):
    services, api = ground
    probe = services.app.state.health
    probe.free = lambda _path: 3 * 1024 * 1024  # 3 MB left, under the 64 MB minimum
    body = await until(api, degraded_by("disk"))
    assert detail(body, "disk") == (
        "3.0 MB free on the disk of the ground's state, telemetry, photos (below 64.0 MB)"
    )
    assert "/" not in detail(body, "disk")  # no path told to an open endpoint
    probe.free = health.free_bytes
    await until(api, ok)


async def test_a_telemetry_store_failing_its_writes_is_a_backlog_and_a_full_disk(
    ground, monkeypatch
):
    services, api = ground
    monkeypatch.setattr(health, "BACKLOG_MAX_AGE_S", 1.0)
    store = services.telemetry
    assert store is not None
    write = store.write

    async def full(points: Any) -> int:
        raise sqlite3.OperationalError("database or disk is full")

    monkeypatch.setattr(store, "write", full)
    fake = await FakeDrone(services.broker_url, "QUAD_1", telemetry_hz=20).start()
    try:
        body = await until(api, degraded_by("telemetry"))
        assert "points not yet written" in detail(body, "telemetry")
        assert "database or disk is full" in detail(body, "telemetry")
        assert detail(body, "disk").startswith("writing telemetry failed: database or disk")
        monkeypatch.setattr(store, "write", write)  # room again: the backlog is written
        await until(api, ok)
        assert services.connector is not None and services.connector.stored > 0
    finally:
        await fake.stop()


async def test_a_planner_task_that_dies_is_503_planner_for_a_while(ground, monkeypatch):
    services, api = ground
    monkeypatch.setattr(health, "RECENT_S", 1.5)

    async def broken() -> None:
        raise RuntimeError("the planner's bookkeeping broke")

    assert services.planner is not None
    services.planner.spawn(broken(), "planner:broken")
    body = await until(api, degraded_by("planner"))
    assert detail(body, "planner") == (
        "planner task planner:broken failed: RuntimeError: the planner's bookkeeping broke"
    )
    await until(api, ok)  # nothing failed since


@contextlib.contextmanager
def small_disk(where: Path, size: str = "4m"):
    """A tmpfs of ``size`` at ``where`` (skips the test where mounting is not allowed)."""
    where.mkdir()
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)],
        capture_output=True,
        check=False,
    )
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {mounted.stderr.decode().strip()}")
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], check=False)


async def test_a_real_disk_filled_up_is_503_disk_and_freed_is_ok(tmp_path):
    with small_disk(tmp_path / "small") as disk:
        broker = Mosquitto(tmp_path)
        url = broker.start()
        try:
            async with ground_on(url, disk) as (services, api):
                services.app.state.health.min_free_bytes = 1024 * 1024  # 1 MB of the 4
                await until(api, ok)
                filler = disk / "filler"
                await asyncio.to_thread(_fill, filler)
                body = await until(api, degraded_by("disk"))
                assert "free on the disk of the ground's state" in detail(body, "disk")
                filler.unlink()
                await until(api, ok)
        finally:
            broker.stop()


def _fill(path: Path) -> None:
    """Write ``path`` until the disk is full."""
    chunk = b"\0" * 65536
    with path.open("wb") as f, contextlib.suppress(OSError):
        while True:
            f.write(chunk)
            f.flush()
