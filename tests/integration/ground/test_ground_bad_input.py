"""Bad REST input gets the right 4xx with a reason, never a 500 — over every endpoint.

Property-based: Hypothesis throws wrong types, unknown commands, out-of-range values, odd drone ids
and junk bodies at each route with no token, a viewer token and an operator token.
"""

from __future__ import annotations

import json
from urllib.parse import quote

import httpx
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dronefleet.ground.services import GroundServices
from dronefleet.messaging.commands import CONTROL_COMMANDS
from support.ground_fakes import FakeDrone, eventually

pytestmark = pytest.mark.integration

SETTINGS = settings(
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

junk = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=20),
    st.lists(st.integers(), max_size=3),
    st.dictionaries(st.text(max_size=5), st.integers(), max_size=3),
)


def seg(text: str) -> str:
    """A path segment as a client would send it (URL-quoted, never empty)."""
    return quote(text, safe="") or "%20"


drone_ids = st.one_of(st.just("QUAD_1"), st.just("NOPE"), st.text(max_size=70))
commands = st.one_of(st.sampled_from(sorted(CONTROL_COMMANDS)), st.text(max_size=20))
params = st.dictionaries(
    st.sampled_from(["value", "lat", "lon", "altitude_delta", "force", "mission", "x"]), junk
)


@pytest.fixture
async def setup(broker, tmp_path):
    ground = GroundServices(
        broker,
        store_url="sqlite://:memory:",
        state_path=tmp_path / "ground.db",
        serve_http=False,
        command_timeout_s=0.3,
    )
    await ground.start()
    drone = await FakeDrone(broker, "QUAD_1").start()
    await eventually(lambda: "QUAD_1" in ground.identifier.fleet)
    viewer = await ground.app.state.ctx.tokens.issue(
        "v", __import__("dronefleet.ground.manager.auth", fromlist=["Role"]).Role.VIEWER
    )
    tokens = {"none": None, "viewer": viewer, "operator": ground.operator_token, "bad": "nope"}
    transport = httpx.ASGITransport(app=ground.app)
    async with httpx.AsyncClient(transport=transport, base_url="http://ground") as client:
        yield client, tokens
    await drone.stop()
    await ground.stop()


def headers(tokens, who):
    token = tokens[who]
    return {"Authorization": f"Bearer {token}"} if token else {}


WHO = st.sampled_from(["none", "viewer", "operator", "bad"])


def check(r: httpx.Response, who: str) -> None:
    assert r.status_code < 500 or r.status_code == 504, (r.status_code, r.text)
    if r.status_code >= 400:
        assert r.json()["detail"], r.text
    if who in {"none", "bad"}:
        assert r.status_code in {401, 404, 405, 422, 429}, r.text


@SETTINGS
@given(who=WHO, drone_id=drone_ids, command=commands, body=st.one_of(junk, params))
async def test_commands(setup, who, drone_id, command, body):
    client, tokens = setup
    r = await client.post(
        f"/api/v1/drones/{seg(drone_id)}/commands/{seg(command)}",
        content=json.dumps(body),
        headers={**headers(tokens, who), "content-type": "application/json"},
        params={"timeout_s": 0.3},
    )
    check(r, who)
    if who == "viewer" and r.status_code not in {404, 405, 422} and drone_id.isidentifier():
        assert r.status_code == 403


@SETTINGS
@given(
    who=WHO,
    query=params,
    command=st.one_of(
        commands, st.sampled_from(["discover", "getgear", "startchain", "stopchain"])
    ),
    drone_id=drone_ids,
    method=st.sampled_from(["GET", "POST"]),
)
async def test_seed_control(setup, who, query, command, drone_id, method):
    client, tokens = setup
    data = {k: str(v) for k, v in query.items()} | {"command": command, "droneID": drone_id}
    if method == "GET":
        r = await client.get("/control", params=data, headers=headers(tokens, who))
    else:
        r = await client.post("/control", data=data, headers=headers(tokens, who))
    check(r, who)


@SETTINGS
@given(
    who=WHO,
    q=st.dictionaries(
        st.sampled_from(["drone", "fields", "from", "to", "every"]), st.text(max_size=30)
    ),
)
async def test_telemetry_query(setup, who, q):
    client, tokens = setup
    r = await client.get("/api/v1/telemetry", params=q, headers=headers(tokens, who))
    check(r, who)


@SETTINGS
@given(who=WHO, drone_id=drone_ids, name=st.text(max_size=70), body=st.one_of(junk, params))
async def test_reads_missions_and_admin(setup, who, drone_id, name, body):
    client, tokens = setup
    h = headers(tokens, who)
    for r in [
        await client.get(f"/api/v1/drones/{seg(drone_id)}", headers=h),
        await client.get(
            f"/api/v1/drones/{seg(drone_id)}/gear", headers=h, params={"timeout_s": 0.3}
        ),
        await client.get(f"/api/v1/drones/{seg(drone_id)}/objects/{seg(name)}", headers=h),
        await client.post(
            f"/api/v1/drones/{seg(drone_id)}/mission", content=json.dumps(body), headers=h
        ),
        await client.post(f"/api/v1/drones/{seg(drone_id)}/mission/stop", headers=h),
        await client.get("/api/v1/audit", params={"limit": name}, headers=h),
        await client.post("/api/v1/tokens", content=json.dumps(body), headers=h),
        await client.delete(f"/api/v1/tokens/{seg(name)}", headers=h),
    ]:
        check(r, who)
