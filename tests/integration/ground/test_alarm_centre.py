"""Issue 29, item 5: the alarm centre's API. A drone's alarms are kept, filtered and
acknowledged (by whom, audited), across a ground restart; the ways around it are refused."""

from __future__ import annotations

import time

import httpx
import pytest

from dronefleet.ground.manager.auth import Role
from dronefleet.ground.services import GroundServices
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.topics import Channel, Direction, topic
from support.ground_fakes import eventually

pytestmark = pytest.mark.integration


def _alarm(drone_id: str, level: str, message: str, t: float) -> dict:
    return {
        "drone_id": drone_id,
        "level": level,
        "message": message,
        "position": {"lat": 40.63, "lon": -8.659, "alt_m": 30.0, "relative_alt_m": 20.0},
        "vehicle_time_s": t,
        "timestamp": time.time(),
    }


def _ground(broker, tmp_path) -> GroundServices:
    return GroundServices(
        broker,
        store_url="sqlite://:memory:",
        state_path=tmp_path / "ground.db",
        serve_http=False,
        command_timeout_s=0.5,
        token="op-token-for-alarms",
    )


async def _client(ground: GroundServices, token: str | None) -> httpx.AsyncClient:
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    transport = httpx.ASGITransport(app=ground.app)
    return httpx.AsyncClient(transport=transport, base_url="http://ground", headers=headers)


@pytest.fixture
async def sender(broker):
    """The drones' side of the broker: publishes on any drone's alarms/out."""
    client = BrokerClient(broker, "alarm-sender")
    await client.start()
    await client.wait_connected(10)
    yield client
    await client.stop()


async def _listed(api: httpx.AsyncClient, n: int, **params) -> dict:
    async def enough():
        page = (await api.get("/api/v1/alarms", params=params)).json()
        return page if len(page["alarms"]) >= n else None

    return await eventually(enough, timeout_s=10)


async def test_an_alarm_is_kept_acknowledged_by_whom_and_survives_a_restart(
    broker, tmp_path, sender
):
    ground = await _ground(broker, tmp_path).start()
    try:
        api = await _client(ground, ground.operator_token)
        critical = _alarm("QUAD_1", "CRITICAL", "battery 15 %: land now", 100.0)
        await sender.publish(topic("QUAD_1", Channel.ALARMS, Direction.OUT), critical)
        page = await _listed(api, 1)
        (entry,) = page["alarms"]
        assert (entry["drone_id"], entry["level"], entry["source"]) == (
            "QUAD_1",
            "CRITICAL",
            "drone",
        )
        assert entry["message"] == "battery 15 %: land now"
        assert entry["acknowledged"] is False and entry["acked_by"] is None
        assert page["unacknowledged"] == 1
        # The same alarm delivered again (a reconnect) is one alarm.
        await sender.publish(topic("QUAD_1", Channel.ALARMS, Direction.OUT), critical)
        later = _alarm("QUAD_1", "WARNING", "wind 11 m/s", 101.0)
        await sender.publish(topic("QUAD_1", Channel.ALARMS, Direction.OUT), later)
        page = await _listed(api, 2)
        assert [a["message"] for a in page["alarms"]] == ["wind 11 m/s", "battery 15 %: land now"]

        r = await api.post(f"/api/v1/alarms/{entry['id']}/ack")
        assert r.status_code == 200, r.text
        assert r.json()["acked_by"] == "operator" and r.json()["acknowledged"] is True
        again = await api.post(f"/api/v1/alarms/{entry['id']}/ack")
        assert again.status_code == 409 and "already acknowledged by operator" in again.text
        audit = await ground.state.read_audit(drone_id="QUAD_1")
        acks = [a for a in audit if a["command"] == "ack_alarm"]
        assert [a["status"] for a in acks] == [409, 200]
        assert acks[1]["who"] == "operator" and acks[1]["params"]["alarm_id"] == entry["id"]
        await api.aclose()
    finally:
        await ground.stop()

    ground = await _ground(broker, tmp_path).start()  # the same state file: a restart
    try:
        api = await _client(ground, "op-token-for-alarms")
        page = (await api.get("/api/v1/alarms", params={"unacknowledged_first": True})).json()
        assert [(a["message"], a["acked_by"]) for a in page["alarms"]] == [
            ("wind 11 m/s", None),
            ("battery 15 %: land now", "operator"),
        ]
        assert page["unacknowledged"] == 1
        latest = (await api.get("/api/v1/alarms/latest")).json()
        assert [(a["drone_id"], a["message"]) for a in latest] == [("QUAD_1", "wind 11 m/s")]
        await api.aclose()
    finally:
        await ground.stop()


async def test_filters_by_drone_level_time_and_acknowledgement(broker, tmp_path, sender):
    ground = await _ground(broker, tmp_path).start()
    api = await _client(ground, ground.operator_token)
    try:
        before = time.time()
        for i, (drone, level) in enumerate(
            [("QUAD_1", "CRITICAL"), ("QUAD_2", "OUT_MEASURE"), ("QUAD_1", "WARNING")]
        ):
            alarm = _alarm(drone, level, f"alarm {i}", float(i))
            await sender.publish(topic(drone, Channel.ALARMS, Direction.OUT), alarm)
        page = await _listed(api, 3)
        ids = {a["message"]: a["id"] for a in page["alarms"]}

        async def messages(**params) -> list[str]:
            r = await api.get("/api/v1/alarms", params=params)
            assert r.status_code == 200, r.text
            return [a["message"] for a in r.json()["alarms"]]

        assert await messages(drone="QUAD_1") == ["alarm 2", "alarm 0"]
        assert await messages(level="OUT_MEASURE") == ["alarm 1"]
        assert await messages(drone="QUAD_2", level="CRITICAL") == []
        assert await messages(since=before - 60, until=time.time() + 60) == [
            "alarm 2",
            "alarm 1",
            "alarm 0",
        ]
        assert await messages(until=before - 60) == []
        assert await messages(limit=1) == ["alarm 2"]
        assert await messages(before_id=ids["alarm 1"]) == ["alarm 0"]
        await api.post(f"/api/v1/alarms/{ids['alarm 1']}/ack")
        assert await messages(acknowledged=True) == ["alarm 1"]
        assert await messages(acknowledged=False) == ["alarm 2", "alarm 0"]
        assert await messages(unacknowledged_first=True) == ["alarm 2", "alarm 0", "alarm 1"]
        r = await api.get("/api/v1/alarms", params={"drone": "QUAD_1"})
        assert r.json()["unacknowledged"] == 2
    finally:
        await api.aclose()
        await ground.stop()


async def test_the_ways_around_it_are_refused(broker, tmp_path, sender):
    """No token: 401; a viewer reads but cannot acknowledge; an alarm forged for another drone
    is not logged; an injection in the drone filter, a huge limit, a bad id: 4xx, never 500."""
    ground = await _ground(broker, tmp_path).start()
    viewer_token = await ground.app.state.ctx.tokens.issue("watcher", Role.VIEWER)
    api = await _client(ground, ground.operator_token)
    viewer = await _client(ground, viewer_token)
    nobody = await _client(ground, None)
    try:
        forged = _alarm("QUAD_2", "CRITICAL", "forged: QUAD_2's alarm on QUAD_1's topic", 1.0)
        await sender.publish(topic("QUAD_1", Channel.ALARMS, Direction.OUT), forged)
        real = _alarm("QUAD_1", "CRITICAL", "real", 2.0)
        await sender.publish(topic("QUAD_1", Channel.ALARMS, Direction.OUT), real)
        (entry,) = (await _listed(api, 1))["alarms"]
        assert entry["message"] == "real"
        await eventually(lambda: ground.planner.dropped["alarm"] >= 1)
        assert (await api.get("/api/v1/alarms")).json()["unacknowledged"] == 1

        assert (await nobody.get("/api/v1/alarms")).status_code == 401
        assert (await nobody.post(f"/api/v1/alarms/{entry['id']}/ack")).status_code == 401
        assert (await viewer.get("/api/v1/alarms")).status_code == 200
        refused = await viewer.post(f"/api/v1/alarms/{entry['id']}/ack")
        assert refused.status_code == 403, refused.text
        for params in (
            {"drone": "QUAD_1' OR '1'='1"},
            {"drone": "QUAD_1/#"},
            {"drone": ""},
            {"drone": "x" * 65},
            {"level": "PANIC"},
            {"limit": 10**9},
            {"limit": 0},
            {"since": -1},
            {"since": 1e300},
            {"since": 2000, "until": 1000},
            {"before_id": 2**64},
            {"acknowledged": "perhaps"},
        ):
            r = await api.get("/api/v1/alarms", params=params)
            assert r.status_code == 422, (params, r.status_code, r.text)
            assert r.json()["detail"], r.text
        for bad, status in (("0", 422), ("-1", 422), ("abc", 422), (str(2**64), 422)):
            r = await api.post(f"/api/v1/alarms/{bad}/ack")
            assert r.status_code == status, (bad, r.text)
        missing = await api.post("/api/v1/alarms/999999/ack")
        assert missing.status_code == 404 and "no alarm 999999" in missing.text
        still = (await api.get("/api/v1/alarms")).json()
        assert still["alarms"][0]["acknowledged"] is False  # nothing above acknowledged it
    finally:
        for client in (api, viewer, nobody):
            await client.aclose()
        await ground.stop()
