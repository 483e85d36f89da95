"""Ground replicas sharing a PostgreSQL state (issue 27, item 2): both serve REST, exactly one
runs the Mission Planner, holding the lease (ground/lease.py); a standby takes over when the
leader stops renewing (dies, hangs) or stops; a replica that loses the database says so in
``GET /api/v1/health`` (503) and does not lead on stale state."""

from __future__ import annotations

import asyncio
import time

import httpx
import pytest

from dronefleet.ground.lease import LEASE_S, RENEW_S
from dronefleet.ground.services import GroundServices
from support.postgres import fresh_database, own_postgres

pytestmark = pytest.mark.integration

TOKEN = "replica-t0ken-for-tests"


def replica(broker: str, state: str, folder, name: str) -> GroundServices:
    return GroundServices(
        broker,
        store_url=f"sqlite:///{folder}/{name}-telemetry.db",
        state_path=state,
        http_port=0,
        token=TOKEN,
        photo_dir=folder / f"{name}-photos",
        planning_processes=0,
    )


async def until(check, timeout_s: float, what: str) -> float:
    """Seconds until ``check()`` is true; fails after ``timeout_s``. Also asserts, at every
    look, that no two replicas lead at once (``check`` raises if they do)."""
    start = time.monotonic()
    while not check():
        if time.monotonic() - start > timeout_s:
            raise AssertionError(f"{what}: not within {timeout_s} s")
        await asyncio.sleep(0.05)
    return time.monotonic() - start


def one_leader(*grounds: GroundServices) -> GroundServices | None:
    leading = [g for g in grounds if g.leading]
    assert len(leading) <= 1, "two replicas run the Mission Planner at once"
    return leading[0] if leading else None


async def get(ground: GroundServices, path: str) -> httpx.Response:
    headers = {"Authorization": f"Bearer {TOKEN}"}
    # 30 s, as the other REST clients of the suite: a loaded host starves one process for long
    async with httpx.AsyncClient(base_url=ground.http_url, timeout=30) as http:
        return await http.get(path, headers=headers)


@pytest.fixture
def shared_state():
    with fresh_database() as url:
        yield url


async def test_one_replica_leads_and_a_standby_takes_over(broker, shared_state, tmp_path):
    a = await replica(broker, shared_state, tmp_path, "a").start()
    b = await replica(broker, shared_state, tmp_path, "b").start()
    try:
        await until(lambda: one_leader(a, b) is not None, 10, "a leader")
        leader = one_leader(a, b)
        standby = b if leader is a else a
        assert leader is not None
        assert await leader.lease.leader() == leader.replica_id  # type: ignore[union-attr]
        for ground in (leader, standby):
            health = await get(ground, "/api/v1/health")
            assert health.status_code == 200, health.text
            # What it says is what it does (on a host loaded past a renewal in 3 s the lease
            # may have changed hands meanwhile, as it should).
            assert health.json()["replica"] == ("leader" if ground.leading else "standby")
            assert (await get(ground, "/api/v1/drones")).status_code == 200
        await until(lambda: one_leader(a, b) is not None, 10, "a leader")
        leader = one_leader(a, b)
        standby = b if leader is a else a
        assert leader is not None
        assert (await get(leader, "/api/v1/missions")).status_code == 200
        refused = await get(standby, "/api/v1/missions")
        assert refused.status_code == 503 and "not running" in refused.json()["detail"]

        # The leader hangs: it renews no more. It stops acting on its own before its lease
        # can pass on, and the standby takes over within a lease and a renewal.
        assert leader.lease is not None and leader.lease._renewer is not None
        leader.lease._renewer.cancel()
        stepped_down = await until(lambda: not leader.leading, LEASE_S + 1, "leader steps down")
        took = await until(lambda: standby.leading, LEASE_S + RENEW_S + 2, "standby takes over")
        assert stepped_down < LEASE_S
        assert stepped_down + took < 5.0
        assert (await get(standby, "/api/v1/missions")).status_code == 200
        one_leader(a, b)

        # The new leader stops cleanly: it gives the lease back and the other one (alive
        # again) takes it at the next renewal.
        await leader.lease.stop()
        await leader.lease.start()
        await standby.stop()
        await until(lambda: leader.leading, RENEW_S + 2, "the first replica leads again")
    finally:
        await b.stop()
        await a.stop()


async def test_a_replica_that_loses_the_database_stops_leading_and_says_so(broker, tmp_path):
    with own_postgres(tmp_path) as server:
        a = await replica(broker, server.url, tmp_path, "a").start()
        try:
            await until(lambda: a.leading, 10, "the replica leads")
            await asyncio.to_thread(server.stop, "immediate")
            lost = await until(lambda: not a.leading, LEASE_S + 1, "leader steps down")
            assert lost < LEASE_S
            health = await get(a, "/api/v1/health")
            assert health.status_code == 503
            assert [p["what"] for p in health.json()["problems"]] == ["state"]
            assert (await get(a, "/api/v1/missions")).status_code == 503
            await asyncio.to_thread(server.start)
            await until(lambda: a.leading, LEASE_S + RENEW_S + 5, "leads again")
            assert (await get(a, "/api/v1/health")).status_code == 200
        finally:
            await a.stop()
