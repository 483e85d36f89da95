"""The web app's sign-in session (ground/manager/session.py, signin.py; issue 12).

Against a running ground over real sockets: a token is exchanged once for a cookie that is
HttpOnly, SameSite=Strict and stored only as a hash; the cookie works for reading, for changes
only with the X-Requested-With header (a forged cross-site form has none), on the live stream,
and not after sign-out or once its token is revoked. Guessing sessions is throttled like tokens.
"""

from __future__ import annotations

import asyncio
import contextlib
import sqlite3
from collections.abc import AsyncIterator
from pathlib import Path
from urllib.parse import urlsplit

import httpx
import pytest
import websockets

from dronefleet.ground.manager.session import SESSION_COOKIE

pytestmark = pytest.mark.integration
CSRF = {"X-Requested-With": "dronefleet"}


async def _new_token(ground, name: str, role: str) -> str:
    admin = {"Authorization": f"Bearer {ground.admin_token}"}
    async with httpx.AsyncClient(base_url=ground.http_url, headers=admin, timeout=10) as client:
        answer = await client.post("/api/v1/tokens", json={"name": name, "role": role})
        assert answer.status_code == 200, answer.text
        return answer.json()["token"]


@contextlib.asynccontextmanager
async def _signed_in(ground, token: str) -> AsyncIterator[tuple[httpx.AsyncClient, httpx.Response]]:
    """A browser-like client that has traded ``token`` for the session cookie."""
    # 30 s: the first preview starts the planning worker's process, slow on a loaded machine.
    async with httpx.AsyncClient(base_url=ground.http_url, timeout=30) as client:
        bearer = {"Authorization": f"Bearer {token}"}
        yield client, await client.post("/api/v1/session", headers=bearer)


async def test_a_token_is_exchanged_for_an_httponly_strict_cookie_kept_only_as_a_hash(ground):
    async with _signed_in(ground, ground.operator_token) as (client, answer):
        assert answer.status_code == 200, answer.text
        assert answer.json() == {"name": "operator", "role": "operator", "can_command": True}
        cookie = answer.headers["set-cookie"]
        assert cookie.startswith(f"{SESSION_COOKIE}=")
        assert "HttpOnly" in cookie and "SameSite=strict" in cookie and "Path=/" in cookie
        session = client.cookies[SESSION_COOKIE]
        assert (await client.get("/api/v1/web/me")).json()["role"] == "operator"
        assert (await client.get("/api/v1/drones")).status_code == 200
    stored = await asyncio.to_thread(_state_bytes, ground)
    assert session.encode() not in stored and ground.operator_token.encode() not in stored
    rows = sqlite3.connect(ground.state_path).execute("SELECT command FROM audit").fetchall()
    assert ("sign-in",) in rows


def _state_bytes(ground) -> bytes:
    """The state database with its write-ahead log, as an attacker reading the disk sees it."""
    wal = Path(ground.state_path + "-wal")
    return Path(ground.state_path).read_bytes() + (wal.read_bytes() if wal.exists() else b"")


async def test_a_change_by_cookie_needs_the_csrf_header(ground):
    async with _signed_in(ground, ground.operator_token) as (client, _):
        body = {"name": "x", "steps": [{"command": "arm"}], "drones": ["QUAD_9"]}
        forged = await client.post("/api/v1/missions/preview", json=body)
        assert forged.status_code == 403
        assert "x-requested-with" in forged.json()["detail"]
        ours = await client.post("/api/v1/missions/preview", json=body, headers=CSRF)
        assert ours.status_code not in (401, 403), ours.text  # past auth: judged on its content


async def test_a_viewer_session_cannot_command(ground):
    viewer = await _new_token(ground, "viewer-1", "viewer")
    async with _signed_in(ground, viewer) as (client, answer):
        assert answer.json()["can_command"] is False
        r = await client.post("/api/v1/drones/QUAD_1/commands/arm", json={}, headers=CSRF)
        assert r.status_code == 403


async def test_sign_out_and_revocation_end_the_session(ground, api):
    """Sign-out ends the session, even for a copy of its cookie; so does revoking its token."""
    async with _signed_in(ground, ground.operator_token) as (client, _):
        session = client.cookies[SESSION_COOKIE]
        out = await client.delete("/api/v1/session", headers=CSRF)
        assert out.status_code == 204
        assert SESSION_COOKIE not in client.cookies
    # A copy of the cookie, replayed after sign-out, is refused.
    async with httpx.AsyncClient(base_url=ground.http_url, timeout=10) as replay:
        replay.cookies.set(SESSION_COOKIE, session)
        assert (await replay.get("/api/v1/web/me")).status_code == 401
    # A session opened with a token ends when the token is revoked.
    viewer = await _new_token(ground, "viewer-2", "viewer")
    async with _signed_in(ground, viewer) as (client, _):
        assert (await client.get("/api/v1/web/me")).status_code == 200
        admin = {"Authorization": f"Bearer {ground.admin_token}"}
        assert (await api.delete("/api/v1/tokens/viewer-2", headers=admin)).status_code == 200
        assert (await client.get("/api/v1/web/me")).status_code == 401


async def test_the_stream_takes_the_cookie_and_bad_sessions_are_throttled(ground):
    async with _signed_in(ground, ground.operator_token) as (client, _):
        session = client.cookies[SESSION_COOKIE]
    host = urlsplit(ground.http_url).netloc
    url = f"ws://{host}/api/v1/stream"
    headers = {"Cookie": f"{SESSION_COOKIE}={session}"}
    async with websockets.connect(url, origin=f"http://{host}", additional_headers=headers) as ws:
        await ws.ping()
    statuses = []
    async with httpx.AsyncClient(base_url=ground.http_url, timeout=10) as guesser:
        for i in range(25):
            guesser.cookies.set(SESSION_COOKIE, f"guess{i}")
            statuses.append((await guesser.get("/api/v1/drones")).status_code)
    assert statuses[:20] == [401] * 20 and set(statuses[20:]) == {429}


async def test_a_session_cookie_alone_does_not_let_a_body_in_unread_but_counts_as_credential(
    ground,
):
    # The hardening layer refuses bodies with no credential before reading them; a session
    # cookie is a credential (the web app's POSTs carry it), an unrelated cookie is not.
    reader, writer = await asyncio.open_connection(*urlsplit(ground.http_url).netloc.split(":"))
    writer.write(
        b"POST /api/v1/missions/preview HTTP/1.1\r\nHost: x\r\nCookie: other=1\r\n"
        b"Content-Type: application/json\r\nContent-Length: 100000000\r\n\r\n{"
    )
    await writer.drain()
    async with asyncio.timeout(10):
        line = await reader.readline()
    writer.close()
    assert line.split()[1] == b"401"
