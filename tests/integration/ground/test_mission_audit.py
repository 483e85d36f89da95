"""A mission refused for an integer out of range is a 422 with the reason AND an audit row
(issue 25 item 5; ground/manager/errors.py, ground/state.py).

Two ways the row was lost: a body refused by its schema on ``/api/v1/missions`` (an int field
sent as ``2**70`` or ``1e400``) was never audited, and an audit row whose parameters held an
integer past 64 bits (``10**30`` in a step sent to a drone) could not be written (orjson
refuses such integers). Bodies are sent as raw JSON text: Python's json would not write 1e400.
"""

from __future__ import annotations

import httpx
import pytest

from dronefleet.ground.manager.auth import Role, TokenBook

pytestmark = pytest.mark.integration

BIG = str(10**30)
HUGE_INT = str(2**70)
AREA = '"polygon": [[40.63, -8.659], [40.631, -8.659], [40.631, -8.658]]'
CAMERA = (
    '"sensor_width_mm": 13.2, "sensor_height_mm": 8.8, "focal_length_mm": 8.8, '
    '"image_height_px": 3648'
)

#: (what, path, the body as sent, the command its audit row names, a part of the reason)
REFUSED = [
    (
        "a take-off altitude of 10**30",
        "/api/v1/missions",
        f'{{"drones": ["QUAD_1"], "steps": [{{"command": "takeoff", "value": {BIG}}}]}}',
        "mission.create",
        "step 0: value",
    ),
    (
        "a sleep of 1e400 s",
        "/api/v1/missions",
        '{"drones": ["QUAD_1"], "steps": [{"command": "sleep", "value": 1e400}]}',
        "mission.create",
        "step 0: value",
    ),
    (
        "collaborators (an int) of 2**70",
        "/api/v1/missions",
        f'{{"drones": ["QUAD_1"], "steps": [{{"command": "sleep", "value": 1}}], '
        f'"options": {{"collaborators": {HUGE_INT}}}}}',
        "mission.create",
        "options.collaborators",
    ),
    (
        "an image width (an int) of 1e400",
        "/api/v1/missions",
        f'{{"drones": ["QUAD_1"], "area": {{{AREA}, "camera": {{{CAMERA}, '
        f'"image_width_px": 1e400}}}}}}',
        "mission.create",
        "image_width_px",
    ),
    (
        "an area altitude of 10**30, previewed",
        "/api/v1/missions/preview",
        f'{{"drones": ["QUAD_1"], "area": {{{AREA}, "altitude_m": {BIG}}}}}',
        "mission.preview",
        "altitude_m",
    ),
    (
        "a step count of 10**30 sent to a drone",
        "/api/v1/drones/QUAD_1/mission",
        f'{{"steps": [{{"command": "sleep", "value": {BIG}}}]}}',
        "startchain",
        "step 0: value",
    ),
    (
        "a start index of 2**70 sent to a drone",
        "/api/v1/drones/QUAD_1/mission",
        f'{{"steps": [{{"command": "sleep", "value": 1}}], "start_index": {HUGE_INT}}}',
        "startchain",
        "start_index",
    ),
]


@pytest.mark.parametrize(
    ("path", "body", "command", "reason"), [r[1:] for r in REFUSED], ids=[r[0] for r in REFUSED]
)
async def test_a_mission_with_an_integer_out_of_range_is_refused_and_audited(
    api, path, body, command, reason
):
    before = (await api.get("/api/v1/audit")).json()
    r = await api.post(path, content=body, headers={"Content-Type": "application/json"})
    assert r.status_code == 422, r.text
    assert reason in r.json()["detail"], r.text
    audit = (await api.get("/api/v1/audit")).json()
    assert len(audit) == len(before) + 1, audit[:2]
    row = audit[0]
    assert (row["command"], row["status"], row["who"]) == (command, 422, "operator")
    assert row["answer"]["detail"] == r.json()["detail"]
    if BIG in body and path.startswith("/api/v1/drones/"):
        assert BIG in str(row["params"])  # what was sent is kept, digit for digit
    assert (await api.get("/api/v1/missions")).json() == []  # nothing was created


async def test_a_refusal_by_a_viewer_is_not_audited_as_the_operators(ground):
    """The audit names who was refused; a request without the operator role is a 403 and
    writes no row claiming otherwise."""
    viewer = await TokenBook(ground.state).issue("viewer", Role.VIEWER)
    headers = {"Authorization": f"Bearer {viewer}", "Content-Type": "application/json"}
    async with httpx.AsyncClient(base_url=ground.http_url, headers=headers, timeout=10) as client:
        body = f'{{"drones": ["QUAD_1"], "options": {{"collaborators": {HUGE_INT}}}}}'
        r = await client.post("/api/v1/missions", content=body)
        assert r.status_code in (403, 422), r.text
    assert [row for row in await ground.state.read_audit() if row["who"] == "viewer"] == []
