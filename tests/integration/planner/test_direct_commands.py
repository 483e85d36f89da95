"""Direct commands respect missions and limits (issue 26, item 4), over REST on virtual time.

Measured before: a direct ``takeoff`` to a drone flying a mission at 20 m was accepted and pulled
it down to 13.4 m mid-mission; a direct ``navigate`` 50 km away was accepted unchecked. Now a
drone refuses flight commands while a mission flies it (409, one sentence naming the mission and
step) unless the mission is paused first or the command is forced (audited, and the mission is
paused for it); ``land`` and ``rtl`` are always obeyed and pause the mission; a ``navigate`` is
checked as a mission step is (battery there and home, fence, altitude: 422 with the reason).
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import httpx
import pytest

from dronefleet.experiments.harness import ORIGIN, Harness
from dronefleet.geo.distance import distance_m
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import NED
from dronefleet.ground.planner import launch
from dronefleet.ground.planner.models import MissionState
from dronefleet.ground.planner.options import MissionOptions

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]

OPTIONS = MissionOptions(
    collaboration=False, replacement=False, early_replacement=False, end_action="hold"
)
WAIT = {"command": "wait_for_flight"}


def to(north: float, east: float, up: float = 20.0) -> dict[str, Any]:
    p = ned_to_lla(NED(north, east), ORIGIN)
    return {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": up}


def body(north: float, east: float, up: float) -> dict[str, Any]:
    """A navigate command's REST body."""
    return {k: v for k, v in to(north, east, up).items() if k != "command"}


#: A square at 20 m with a long hover at each corner: 12 steps, about two minutes.
STEPS = [
    step
    for corner in ((40, 0), (40, 40), (0, 40), (0, 0))
    for step in (to(*corner), WAIT, {"command": "sleep", "value": 20})
]


@asynccontextmanager
async def flying(hovering_m: float = 20.0) -> AsyncIterator[tuple[Harness, httpx.AsyncClient, str]]:
    """QUAD_A hovering at 20 m and flying :data:`STEPS` (its second step under way), and an
    operator's REST client on the ground's app."""
    async with Harness(speedup=20) as h:
        await h.add_drone("QUAD_A", NED(0, 0), hovering_m=hovering_m)
        await h.wait_identified(["QUAD_A"])
        await h.settle()
        spec = launch.MissionSpec(name="square", drones=["QUAD_A"], steps=STEPS, options=OPTIONS)
        record = await launch.create(h.planner, spec, start=True)
        await h.settle(8.0)  # on its way to the first corner
        assert record.state is MissionState.RUNNING, record.error
        assert h.ground is not None
        transport = httpx.ASGITransport(app=h.ground.app)
        headers = {"Authorization": f"Bearer {h.ground.operator_token}"}
        async with httpx.AsyncClient(
            transport=transport, base_url="http://ground", headers=headers, timeout=60
        ) as api:
            yield h, api, record.mission_id


async def until(h: Harness, predicate: Any, timeout_s: float = 30.0) -> None:
    for _ in range(int(timeout_s / 0.2)):
        if predicate():
            return
        await h.clock.sleep(0.2)
    raise AssertionError("not within the time given")


async def last_audit(api: httpx.AsyncClient, command: str) -> dict[str, Any]:
    rows = (await api.get("/api/v1/audit", params={"drone": "QUAD_A"})).json()
    return next(row for row in rows if row["command"] == command)


def height(h: Harness) -> float:
    return h.fleet.vehicle("QUAD_A").relative_alt_m


async def test_a_drone_flying_a_mission_refuses_takeoff_and_navigate_until_paused():
    async with flying() as (h, api, mission_id):
        worker = h.fleet.apps["QUAD_A"].mission_worker
        for command, sent in (("takeoff", {"value": 10}), ("navigate", body(0, 0, 8))):
            r = await api.post(f"/api/v1/drones/QUAD_A/commands/{command}", json=sent)
            assert r.status_code == 409, r.text
            detail = r.json()["detail"]
            assert detail.startswith(f"QUAD_A is flying mission {mission_id}."), detail  # its leg
            assert " (step " in detail, detail
            assert detail.endswith(": pause or abort it first, or force"), detail
            assert r.json()["mission"]["mission_id"].startswith(mission_id)
            assert (await last_audit(api, command))["status"] == 409
        # Nothing changed: the mission flies on at its height.
        await h.settle(5.0)
        assert abs(height(h) - 20.0) < 1.0, height(h)
        assert worker.flying() is not None
        assert h.planner.missions[mission_id].state is MissionState.RUNNING

        # Paused from the ground, the drone holds and takes direct commands.
        assert (await api.post("/api/v1/drones/QUAD_A/pause")).status_code == 200
        await until(h, lambda: h.planner.missions[mission_id].state is MissionState.PAUSED)
        r = await api.post("/api/v1/drones/QUAD_A/commands/takeoff", json={"value": 12})
        assert r.status_code == 200, r.text
        await until(h, lambda: abs(height(h) - 12.0) < 0.5)
        # Resumed, it flies the rest of the mission (back at its 20 m).
        assert (await api.post("/api/v1/drones/QUAD_A/resume")).status_code == 200
        await until(h, lambda: h.planner.missions[mission_id].state is MissionState.RUNNING)
        await until(h, lambda: abs(height(h) - 20.0) < 1.0)


async def test_a_forced_command_flies_pauses_the_mission_and_is_audited_with_who():
    async with flying() as (h, api, mission_id):
        r = await api.post(
            "/api/v1/drones/QUAD_A/commands/takeoff", json={"value": 12, "force": True}
        )
        assert r.status_code == 200, r.text
        await until(h, lambda: abs(height(h) - 12.0) < 0.5)
        record = h.planner.missions[mission_id]
        await until(h, lambda: record.state is MissionState.PAUSED)
        assert "paused for a direct takeoff command (forced by operator)" in (record.error or "")
        row = await last_audit(api, "takeoff")
        assert (row["status"], row["who"], row["params"].get("force")) == (200, "operator", True)
        # The mission waits: it does not take the vehicle back to 20 m.
        await h.settle(10.0)
        assert abs(height(h) - 12.0) < 0.5, height(h)
        # The seed's /control endpoint takes force too (a form's "true").
        r = await api.post(
            "/control",
            data={"command": "altitude", "droneID": "QUAD_A", "value": "3", "force": "true"},
        )
        assert r.status_code == 200, r.text


async def test_land_is_obeyed_mid_mission_and_the_mission_does_not_take_off_again():
    async with flying() as (h, api, mission_id):
        r = await api.post("/api/v1/drones/QUAD_A/commands/land")
        assert r.status_code == 200, r.text
        record = h.planner.missions[mission_id]
        await until(h, lambda: record.state is MissionState.PAUSED)
        assert "paused for a direct land command (sent by operator)" in (record.error or "")
        await until(h, lambda: not h.fleet.apps["QUAD_A"].fc.state().in_air, timeout_s=60)
        await h.settle(15.0)
        assert height(h) < 0.5 and not h.fleet.apps["QUAD_A"].fc.state().in_air


async def test_navigate_is_checked_like_a_mission_step():
    async with Harness(speedup=20) as h:
        await h.add_drone("QUAD_A", NED(0, 0), hovering_m=10)
        await h.wait_identified(["QUAD_A"])
        await h.settle()
        assert h.ground is not None
        transport = httpx.ASGITransport(app=h.ground.app)
        headers = {"Authorization": f"Bearer {h.ground.operator_token}"}
        async with httpx.AsyncClient(
            transport=transport, base_url="http://ground", headers=headers, timeout=60
        ) as api:
            far = body(50_000, 0, 10)
            r = await api.post("/api/v1/drones/QUAD_A/commands/navigate", json=far)
            assert r.status_code == 422, r.text
            detail = r.json()["detail"]
            assert "(50.0 km from home) and back" in detail and "reserve" in detail, detail
            row = await last_audit(api, "navigate")
            assert row["status"] == 422 and row["answer"]["detail"] == detail
            # Forcing it changes nothing: force is about missions, not batteries.
            r = await api.post(
                "/api/v1/drones/QUAD_A/commands/navigate", json={**far, "force": True}
            )
            assert r.status_code == 422, r.text
            # A relative move is checked too (from where the drone is).
            r = await api.post("/api/v1/drones/QUAD_A/commands/changeN", json={"value": 4_900})
            assert r.status_code == 422 and "(4.9 km from home)" in r.json()["detail"], r.text
            r = await api.post("/api/v1/drones/QUAD_A/commands/navigate", json=body(100, 0, 10))
            assert r.status_code == 200, r.text
            fc = h.fleet.apps["QUAD_A"].fc
            near = ned_to_lla(NED(100, 0), ORIGIN)
            await until(h, lambda: distance_m(fc.position(), near) < 2.0, timeout_s=60)
