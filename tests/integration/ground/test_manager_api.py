"""The Drone Manager's REST API against fake drones on an embedded broker (seed 4.2.3, 4.3.3)."""

from __future__ import annotations

import asyncio
import time

import httpx
import pytest

from dronefleet.messaging.missions import encode_steps_base64
from support.ground_fakes import FakeDrone, eventually

pytestmark = pytest.mark.integration


async def online(api: httpx.AsyncClient, drone_id: str) -> dict:
    async def seen():
        r = await api.get(f"/api/v1/drones/{drone_id}")
        return r.json() if r.status_code == 200 and r.json()["status"] == "online" else None

    return await eventually(seen)


async def test_an_arm_request_reaches_the_drone_and_its_answer_comes_back(api, drone):
    await online(api, "QUAD_1")
    r = await api.post("/api/v1/drones/QUAD_1/commands/arm")
    assert r.status_code == 200, r.text
    assert r.json()["ok"] is True and r.json()["command"] == "arm"
    sent = drone.received[-1]
    assert sent["command"] == "arm" and len(sent["request_id"]) == 32  # 16 random bytes, hex


async def test_a_typed_body_is_checked_before_anything_is_sent(api, drone):
    await online(api, "QUAD_1")
    r = await api.post("/api/v1/drones/QUAD_1/commands/navigate", json={"lat": 91, "lon": 0})
    assert r.status_code == 422 and "lat" in r.json()["detail"]
    r = await api.post("/api/v1/drones/QUAD_1/commands/changeN", json={"value": "north"})
    assert r.status_code == 422
    r = await api.post("/api/v1/drones/QUAD_1/commands/fly")
    assert r.status_code == 404 and "unknown command" in r.json()["detail"]
    # (A move is checked as a mission step: 100 m from the drone, not the 6 km this was.)
    r = await api.post(
        "/api/v1/drones/QUAD_1/commands/navigate",
        json={"lat": 40.631, "lon": -8.659, "altitude_delta": 5},
    )
    assert r.status_code == 200, r.text
    assert drone.received[-1]["lat"] == 40.631
    assert not [m for m in drone.received if m.get("lat") == 91]


async def test_the_fleet_has_gear_and_an_unknown_drone_is_404(api, drone):
    await online(api, "QUAD_1")
    gear = await eventually(
        lambda: api.get("/api/v1/drones/QUAD_1/gear"),
    )
    assert gear.status_code == 200 and gear.json()["specs"]["frame"] == "quad"
    fleet = (await api.get("/api/v1/drones")).json()
    assert [d["drone_id"] for d in fleet] == ["QUAD_1"]
    r = await api.get("/api/v1/drones/NOPE")
    assert r.status_code == 404 and "NOPE" in r.json()["detail"]
    r = await api.post("/api/v1/drones/NOPE/commands/arm")
    assert r.status_code == 404


async def test_a_silent_drone_gives_504_and_a_lost_drone_409_with_last_seen(api, broker):
    silent = await FakeDrone(broker, "MUTE", interval_s=0.1, answer=False).start()
    try:
        await online(api, "MUTE")
        started = time.monotonic()
        r = await api.post("/api/v1/drones/MUTE/commands/arm", params={"timeout_s": 0.5})
        assert r.status_code == 504 and "did not answer" in r.json()["detail"]
        assert time.monotonic() - started < 3
    finally:
        await silent.stop()

    async def lost():
        r = await api.post("/api/v1/drones/MUTE/commands/arm")
        return r if r.status_code == 409 else None

    r = await eventually(lost, timeout_s=5)
    assert "not connected" in r.json()["detail"] and r.json()["last_seen"] > 0


async def test_roles_decide_who_may_command(ground, drone):
    async with httpx.AsyncClient(base_url=ground.http_url) as anon:
        assert (await anon.get("/api/v1/drones")).status_code == 401
        assert (await anon.get("/api/v1/drones", headers={"X-API-Token": "x"})).status_code == 401
        admin = {"Authorization": f"Bearer {ground.admin_token}"}
        made = await anon.post(
            "/api/v1/tokens", json={"name": "eve", "role": "viewer"}, headers=admin
        )
        assert made.status_code == 200
        viewer = {"Authorization": f"Bearer {made.json()['token']}"}
        assert (await anon.get("/api/v1/drones", headers=viewer)).status_code == 200
        r = await anon.post("/api/v1/drones/QUAD_1/commands/arm", headers=viewer)
        assert r.status_code == 403 and "viewer" in r.json()["detail"]
        op = {"Authorization": f"Bearer {ground.operator_token}"}
        assert (await anon.get("/api/v1/tokens", headers=op)).status_code == 403
        names = [t["name"] for t in (await anon.get("/api/v1/tokens", headers=admin)).json()]
        assert set(names) == {"operator", "admin", "eve"}
        assert (await anon.delete("/api/v1/tokens/eve", headers=admin)).status_code == 200
        assert (await anon.get("/api/v1/drones", headers=viewer)).status_code == 401


async def test_every_command_is_in_the_audit_log(api, drone):
    await online(api, "QUAD_1")
    await api.post("/api/v1/drones/QUAD_1/commands/arm")
    await api.post("/api/v1/drones/QUAD_1/commands/takeoff", json={"value": 5000})
    audit = (await api.get("/api/v1/audit", params={"drone": "QUAD_1"})).json()
    assert [(a["command"], a["status"], a["who"]) for a in audit] == [
        ("takeoff", 422, "operator"),
        ("arm", 200, "operator"),
    ]
    assert audit[1]["answer"]["ok"] is True


async def test_the_seeds_control_endpoint(api, drone):
    await online(api, "QUAD_1")
    r = await api.get("/control", params={"command": "discover"})
    assert r.status_code == 200 and r.json()[0]["drone_id"] == "QUAD_1"
    r = await api.post("/control", data={"command": "arm", "droneID": "QUAD_1"})
    assert r.status_code == 200 and r.json()["ok"] is True
    r = await api.post("/control?command=changeN&droneID=QUAD_1&value=12.5")
    assert r.status_code == 200 and drone.received[-1]["value"] == 12.5
    r = await api.get("/control", params={"command": "arm", "droneID": "QUAD_1"})
    assert r.status_code == 405
    r = await api.post("/control", data={"command": "navigate", "droneID": "QUAD_1", "lat": "x"})
    assert r.status_code == 422 and "lat" in r.json()["detail"]
    mission = encode_steps_base64([{"command": "arm"}, {"command": "takeoff"}])
    r = await api.post(
        "/control", data={"command": "startchain", "droneID": "QUAD_1", "mission": mission}
    )
    assert r.status_code == 200 and r.json()["event"] == "accepted"
    r = await api.post(
        "/control", data={"command": "startchain", "droneID": "QUAD_1", "mission": "!!"}
    )
    assert r.status_code == 422 and "base64" in r.json()["detail"]
    r = await api.post("/control", data={"command": "stopchain", "droneID": "QUAD_1"})
    assert r.status_code == 200 and r.json()["event"] == "stopped"


async def test_telemetry_is_stored_and_queried_downsampled(api, ground, drone):
    t0 = time.time()
    await eventually(lambda: ground.connector.stored >= 30, timeout_s=5)
    r = await api.get(
        "/api/v1/telemetry",
        params={"drone": "QUAD_1", "from": t0 - 5, "to": time.time() + 1, "every": "500ms"},
    )
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["fields"] == ["alt_m", "battery_pct"]
    times = [t for t, _ in body["series"]["alt_m"]]
    assert times == sorted(times) and all(abs((t / 0.5) - round(t / 0.5)) < 1e-6 for t in times)
    bad = await api.get("/api/v1/telemetry", params={"drone": "QUAD_1", "every": "soon"})
    assert bad.status_code == 422


async def test_the_stream_carries_heartbeats_and_fleet_changes(ground, drone):
    import websockets

    url = ground.http_url.replace("http", "ws") + "/api/v1/stream"
    async with websockets.connect(f"{url}?token={ground.operator_token}&kinds=heartbeat") as ws:
        message = await asyncio.wait_for(ws.recv(), 5)
    assert '"kind":"heartbeat"' in message.replace(" ", "") and "QUAD_1" in message
    try:
        async with websockets.connect(f"{url}?token=wrong") as ws:
            await ws.recv()
        raise AssertionError("a bad token must not get a stream")
    except websockets.exceptions.InvalidStatus as exc:
        assert exc.response.status_code == 403
    except websockets.exceptions.ConnectionClosed:
        pass
