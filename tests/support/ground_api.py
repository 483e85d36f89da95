"""Ground services in this process, with an operator's and a viewer's REST client once the
drones a test needs are heard, and a mission flown through REST: the set-up of the planner's
REST tests."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import httpx

from dronefleet.ground.manager.auth import Role, TokenBook
from dronefleet.ground.services import GroundServices


def heard(*drone_ids: str) -> Callable[[list[dict[str, Any]]], bool]:
    """Ready when the fleet lists exactly these drones."""
    return lambda fleet: {d["drone_id"] for d in fleet} == set(drone_ids)


def local_ground(broker: Any, tmp_path: Path, planner_client_id: str) -> GroundServices:
    """Ground services on ``broker`` with their stores in ``tmp_path`` and REST on a free port."""
    return GroundServices(
        broker,
        store_url=f"sqlite:///{tmp_path}/t.db",
        state_path=tmp_path / "g.db",
        http_port=0,
        planner_client_id=planner_client_id,
    )


async def flown(api: httpx.AsyncClient, spec: dict[str, Any], timeout_s: float = 120) -> dict:
    """Create and start the mission ``spec`` (201, or the test fails with the answer) and wait
    until it has ended: its detail (``GET /api/v1/missions/{id}``)."""
    created = await api.post("/api/v1/missions", params={"start": "true"}, json=spec)
    assert created.status_code == 201, created.text
    mission_id = created.json()["mission_id"]
    for _ in range(int(timeout_s / 0.1)):
        detail = (await api.get(f"/api/v1/missions/{mission_id}")).json()
        if detail["state"] in ("completed", "failed", "stopped"):
            return detail
        await asyncio.sleep(0.1)
    raise AssertionError(f"mission {mission_id} still {detail['state']} after {timeout_s:g} s")


@asynccontextmanager
async def ground_clients(
    broker: Any,
    tmp_path: Path,
    planner_client_id: str,
    ready: Callable[[list[dict[str, Any]]], bool],
) -> AsyncIterator[tuple[httpx.AsyncClient, httpx.AsyncClient]]:
    """(operator, viewer) clients of ground services on ``broker``, after ``ready`` holds for
    ``GET /api/v1/drones`` (10 s at most: a test then fails on what it misses)."""
    ground = local_ground(broker, tmp_path, planner_client_id)
    async with ground:
        viewer = await TokenBook(ground.state).issue("viewer", Role.VIEWER)
        # 30 s: the first plan starts the planning worker's process, slow on a loaded machine.
        # Idle connections are let go after 1 s, before the ground closes them (its keep-alive
        # is 2 s, ground/services.py; httpx keeps them 5 s): a request sent on a connection the
        # server was closing failed with ReadError when the shared event loop stalled > 2 s.
        limits = httpx.Limits(keepalive_expiry=1.0)
        op = httpx.AsyncClient(
            base_url=ground.http_url,
            headers={"Authorization": f"Bearer {ground.operator_token}"},
            timeout=30,
            limits=limits,
        )
        view = httpx.AsyncClient(
            base_url=ground.http_url,
            headers={"Authorization": f"Bearer {viewer}"},
            timeout=30,
            limits=limits,
        )
        async with op, view:
            for _ in range(100):
                if ready((await op.get("/api/v1/drones")).json()):
                    break
                await asyncio.sleep(0.1)
            yield op, view
