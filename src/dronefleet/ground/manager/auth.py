"""API tokens with roles: viewer (read), operator (commands, missions), admin (tokens, config).

Tokens are random strings handed out once; the state store keeps only their SHA-256 (a token is
32 random bytes, so a plain hash is enough). A request carries its token as
``Authorization: Bearer <token>`` or ``X-API-Token: <token>``; ``?token=`` only on the live
stream's WebSocket and the seed's ``/control`` links. The web app instead holds an HttpOnly
session cookie (``session.py``), opened with a token once. Missing or unknown token: 401; a role
too low: 403. Other headers (``X-API-Key``, ``Cookie`` values other than the session) are not
credentials and are ignored, so a request carrying only them is a 401 like one with none.
"""

from __future__ import annotations

import hashlib
import secrets
from dataclasses import dataclass
from enum import IntEnum

from starlette.requests import HTTPConnection

from dronefleet.ground.manager.errors import ApiError
from dronefleet.ground.manager.hardening import AuthThrottle
from dronefleet.ground.manager.session import CSRF_HEADER, SESSION_COOKIE, SessionBook
from dronefleet.ground.state import StateStore


class Role(IntEnum):
    VIEWER = 1
    OPERATOR = 2
    ADMIN = 3

    @classmethod
    def parse(cls, name: str) -> Role:
        try:
            return cls[name.upper()]
        except KeyError as exc:
            raise ValueError(f"unknown role {name!r}; use viewer, operator or admin") from exc

    @property
    def label(self) -> str:
        return self.name.lower()


@dataclass(frozen=True)
class Principal:
    name: str
    role: Role


def new_token() -> str:
    return secrets.token_urlsafe(32)


def hash_token(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


def token_from(conn: HTTPConnection) -> str | None:
    """The request's token: a header, or ``?token=`` only where a header cannot be set (the
    browser's WebSocket) or the seed's clients put it (``/control``). A token in the URL of an
    ordinary API call would end in logs and browser histories, so it is not looked at."""
    auth = conn.headers.get("authorization", "")
    if auth.lower().startswith("bearer "):
        return auth[7:].strip() or None
    header = conn.headers.get("x-api-token")
    if header:
        return header
    if conn.scope.get("type") == "websocket" or conn.url.path == "/control":
        return conn.query_params.get("token") or None
    return None


class TokenBook:
    """Tokens in the state store, with an in-memory cache of the ones seen."""

    def __init__(self, state: StateStore) -> None:
        self.state = state
        self._cache: dict[str, Principal] = {}
        self.throttle = AuthThrottle()
        self.sessions = SessionBook(state)

    async def issue(self, name: str, role: Role, token: str | None = None) -> str:
        """Create (or replace) the token called ``name``; return the token itself."""
        token = token or new_token()
        await self.state.add_token(hash_token(token), name, role.label)
        self._cache.clear()
        self.sessions.forget()  # a replaced token's sessions end with it
        return token

    async def issue_if_none(self, name: str, role: Role) -> str | None:
        """A new token called ``name`` unless one exists (then None): a first start's."""
        token = new_token()
        if not await self.state.add_token_if_none(hash_token(token), name, role.label):
            return None
        self._cache.clear()
        return token

    async def revoke(self, name: str) -> bool:
        self._cache.clear()
        self.sessions.forget()
        return await self.state.delete_token(name)

    async def has_any(self) -> bool:
        return bool(await self.state.list_tokens())

    async def authenticate(self, conn: HTTPConnection) -> Principal:
        """Who makes this request: by its token, else by the web app's session cookie; 401 (or
        429, throttled) for neither or an unknown one. Needs only the headers: the Drone
        Manager's hardening asks it before a request's body is read."""
        token = token_from(conn)
        if token:
            return await self.by_token(conn, token)
        if session := conn.cookies.get(SESSION_COOKIE):
            return await self._by_session(conn, session)
        raise ApiError(401, "missing API token: send 'Authorization: Bearer <token>'")

    async def principal(self, conn: HTTPConnection, need: Role) -> Principal:
        """Who makes this request, if their role is at least ``need`` (403 if not)."""
        principal = await self.authenticate(conn)
        if principal.role < need:
            raise ApiError(
                403,
                f"token {principal.name!r} is a {principal.role.label}; this needs {need.label}",
            )
        return principal

    async def by_token(self, conn: HTTPConnection, token: str) -> Principal:
        digest = hash_token(token)
        principal = self._cache.get(digest)
        if principal is None:
            client = AuthThrottle.client_of(conn.scope)
            if self.throttle.blocked(client):
                raise ApiError(429, "too many unknown API tokens from this client; wait a minute")
            found = await self.state.find_token(digest)
            if found is None:
                self.throttle.failed(client)
                raise ApiError(401, "unknown API token")
            principal = Principal(found[0], Role.parse(found[1]))
            self._cache[digest] = principal
        return principal

    async def _by_session(self, conn: HTTPConnection, session: str) -> Principal:
        client = AuthThrottle.client_of(conn.scope)
        found = await self.sessions.find(session)
        if found is None:
            if self.throttle.blocked(client):
                raise ApiError(429, "too many unknown sessions from this client; wait a minute")
            self.throttle.failed(client)
            raise ApiError(401, "the sign-in session has ended: sign in again with a token")
        method = conn.scope.get("method", "GET")
        if method not in ("GET", "HEAD", "OPTIONS") and CSRF_HEADER not in conn.headers:
            # A cookie rides along with any request the browser makes, a forged one included.
            raise ApiError(403, f"a signed-in change needs the {CSRF_HEADER} header")
        return Principal(found[0], Role.parse(found[1]))
