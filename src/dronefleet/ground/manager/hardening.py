"""HTTP hardening in front of every route (issue 12): body limits, security headers, auth throttle.

- **Bodies are bounded before they are read.** A body whose request carries no credential, or one
  the ground does not know (a wrong token, an ended session: 401; a client over the failed-login
  limit: 429), is refused before a byte of it is buffered: the credential is checked from the
  headers alone (``auth.TokenBook.authenticate``). A known one's body over :data:`MAX_BODY_BYTES`
  is refused (413) by its Content-Length, or while it streams in when it has none. The largest
  legitimate body, a 10,000-step mission, is ~1 MB. (Before issue 25, only a credential's presence
  was checked here: 40 bodies of 3.5 MiB with a wrong token were parsed before their 401.)
- **Headers a browser obeys**: a strict Content-Security-Policy for the web app (scripts only
  from this server; no inline script; styles inline only, as Leaflet positions with them; map
  tiles only from the tile server the ground was given), framing refused, no MIME sniffing, no
  referrer. The API docs (``/docs``: Swagger UI from npm, served by the ground, manager/docs.py)
  get a policy that allows this server only, as the app's does.
- **Failed authentication is throttled per client** (:class:`AuthThrottle`, used by
  ``auth.TokenBook``): after :data:`MAX_FAILURES` unknown tokens in :data:`WINDOW_S` seconds, a
  client's new tokens are not looked up but answered 429 until the window has passed (a token
  already in use keeps working, so guessing costs an attacker and not the operator). The client is
  the connection's peer: ``X-Forwarded-For`` is believed only from a proxy the ground was told to
  trust (``dronefleet ground --trusted-proxy ADDR``; uvicorn's proxy-headers handling, given only
  those addresses), never by default, so a forged header cannot buy a fresh budget.

A plain ASGI middleware rather than Starlette's ``BaseHTTPMiddleware``, so a refused body is never
buffered and WebSockets pass untouched.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Awaitable, Callable, MutableMapping
from typing import Any
from urllib.parse import parse_qsl, urlsplit

import orjson
from starlette.requests import HTTPConnection

from dronefleet.errors import InvalidInput
from dronefleet.ground.manager.errors import ApiError

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

MAX_BODY_BYTES = 4 * 1024 * 1024
MAX_FAILURES = 20
WINDOW_S = 60.0

APP_POLICY = (
    "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
    "img-src 'self' data: blob:{tiles}; connect-src 'self' ws: wss:; font-src 'self'; "
    "object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'"
)
DOCS_POLICY = (
    "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
    "img-src 'self' data:; font-src 'self'; connect-src 'self'; object-src 'none'; "
    "base-uri 'none'; form-action 'self'; frame-ancestors 'none'"
)
_HEADERS = [
    (b"x-frame-options", b"DENY"),
    (b"x-content-type-options", b"nosniff"),
    (b"referrer-policy", b"no-referrer"),
]
_CREDENTIALS = (b"authorization", b"x-api-token")
_SESSION = b"dronefleet_session="  # the web app's session cookie (manager/session.py)


class BodyTooLarge(InvalidInput):
    """A body that grew past the limit while it was read."""


class AuthThrottle:
    """Failed authentications per client address in a sliding window."""

    def __init__(self, max_failures: int = MAX_FAILURES, window_s: float = WINDOW_S) -> None:
        self.max_failures, self.window_s = max_failures, window_s
        self._failures: dict[str, deque[float]] = {}

    def _recent(self, client: str, now: float) -> deque[float]:
        times = self._failures.setdefault(client, deque())
        while times and now - times[0] > self.window_s:
            times.popleft()
        return times

    @staticmethod
    def client_of(scope: Scope) -> str:
        client = scope.get("client")
        return str(client[0]) if client else "unknown"

    def blocked(self, client: str) -> bool:
        now = time.monotonic()
        blocked = len(self._recent(client, now)) >= self.max_failures
        if not self._failures[client]:
            del self._failures[client]
        return blocked

    def failed(self, client: str) -> None:
        now = time.monotonic()
        self._recent(client, now).append(now)
        if len(self._failures) > 10_000:  # a flood of addresses must not grow memory unbounded
            self._failures.pop(next(iter(self._failures)))


class Hardening:
    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = dict(scope.get("headers") or [])
        length = _content_length(headers)
        has_body = (length is not None and length > 0) or b"transfer-encoding" in headers
        if has_body:
            refusal = await _unauthenticated(scope, headers)
            if refusal is not None:
                await _refuse(send, *refusal)
                return
        if length is not None and length > MAX_BODY_BYTES:
            await _refuse(send, 413, f"request body over {MAX_BODY_BYTES} bytes")
            return
        repeated = _repeated_parameter(scope.get("query_string", b""))
        if repeated is not None:  # as FastAPI answers a parameter that does not fit (422)
            why = "given more than once: give it once"
            error = {"loc": ["query", repeated], "msg": why, "type": "repeated"}
            await _refuse(send, 422, f"query.{repeated}: {why}", {"errors": [error]})
            return
        await self._serve(scope, receive, send)

    async def _serve(self, scope: Scope, receive: Receive, send: Send) -> None:
        path = scope.get("path", "")
        policy = DOCS_POLICY if path in ("/docs", "/redoc") else _app_policy(scope)
        seen = 0
        started = False

        async def bounded_receive() -> Message:
            nonlocal seen
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > MAX_BODY_BYTES:
                    raise BodyTooLarge(f"request body over {MAX_BODY_BYTES} bytes")
            return message

        async def send_with_headers(message: Message) -> None:
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
                message["headers"] = [
                    *message.get("headers", []),
                    *_HEADERS,
                    (b"content-security-policy", policy.encode()),
                ]
            await send(message)

        try:
            await self.app(scope, bounded_receive, send_with_headers)
        except BodyTooLarge:
            if not started:
                await _refuse(send, 413, f"request body over {MAX_BODY_BYTES} bytes")


def _repeated_parameter(query: bytes) -> str | None:
    """The first parameter ``query`` gives more than once (cut to 64 characters), or None. Every
    parameter of the API takes one value: given twice (``?drone=A&drone=B``), FastAPI would read
    the last and answer as if the others had not been sent (the OpenAPI fuzzer's find: a list
    where the schema says one string, answered 200)."""
    if b"&" not in query:
        return None
    seen: set[str] = set()
    for name, _value in parse_qsl(query.decode("latin-1"), keep_blank_values=True):
        if name in seen:
            return name[:64]
        seen.add(name)
    return None


async def _unauthenticated(
    scope: Scope, headers: dict[bytes, bytes]
) -> tuple[int, str, dict[str, Any]] | None:
    """Why a request with a body is refused before the body is read (status, reason, extra
    fields), or None when its credential is known. Only the headers are looked at; the route
    checks the role again (from the TokenBook's cache) once the body is in."""
    tokens = getattr(getattr(getattr(scope.get("app"), "state", None), "ctx", None), "tokens", None)
    if tokens is None:  # an app without a token book (never the ground's): presence only
        sent = (
            any(h in headers for h in _CREDENTIALS)
            or b"token=" in scope.get("query_string", b"")
            or _SESSION in headers.get(b"cookie", b"")
        )
        return (
            None if sent else (401, "missing API token: send 'Authorization: Bearer <token>'", {})
        )
    try:
        await tokens.authenticate(HTTPConnection(scope))
    except ApiError as exc:
        body = exc.body()
        return exc.status, str(body.pop("detail")), body
    return None


def _app_policy(scope: Scope) -> str:
    """The web app's policy; map tiles may come only from the tile server the ground was given
    (``--tiles``: the app's ``web_tiles``), and from nowhere else."""
    app = scope.get("app")
    template = getattr(getattr(app, "state", None), "web_tiles", None)
    origin = ""
    if isinstance(template, str):
        parts = urlsplit(template.replace("{s}", "a"))
        if parts.scheme in ("http", "https") and parts.netloc:
            host = parts.netloc.replace("a.", "*.", 1) if "{s}" in template else parts.netloc
            origin = f" {parts.scheme}://{host}"
    return APP_POLICY.format(tiles=origin)


def _content_length(headers: dict[bytes, bytes]) -> int | None:
    raw = headers.get(b"content-length")
    try:
        return int(raw) if raw is not None else None
    except ValueError:
        return None


async def _refuse(
    send: Send, status: int, detail: str, extra: dict[str, Any] | None = None
) -> None:
    body = orjson.dumps({"detail": detail, **(extra or {})})
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(body)).encode()),
                *_HEADERS,
            ],
        }
    )
    await send({"type": "http.response.body", "body": body})
