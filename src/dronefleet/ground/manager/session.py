"""The web app's sign-in session (issue 12): an HttpOnly cookie instead of a token in the page.

A person signs in once with an API token (the demo's printed link, or the sign-in dialog); the
Drone Manager answers with a session cookie that page script cannot read (``HttpOnly``), that
no other site's page sends (``SameSite=Strict``), and that lives at most :data:`SESSION_TTL_S`.
An injected script can then no longer carry the operator's token away: the worst it can do is
act from inside the page while it is open, which the Content-Security-Policy already forbids.

The state store keeps only each session id's SHA-256 (like tokens, 32 random bytes) and the hash
of the token it was opened with: revoking or replacing that token ends its sessions at once.
Expiry is measured on the wall clock, not vehicle time: it bounds how long a stolen cookie is
good for a person, whatever the simulation's speed-up.
"""

from __future__ import annotations

import hashlib
import secrets
import time

from dronefleet.ground.state import StateStore

SESSION_COOKIE = "dronefleet_session"
SESSION_TTL_S = 12 * 3600
#: Browsers send the session cookie with any same-site request; a request that changes something
#: must also carry this header, which a form or an <img> from elsewhere cannot set (and a
#: cross-site fetch() may set only after a CORS preflight this server never grants).
CSRF_HEADER = "x-requested-with"

_SCHEMA = """
CREATE TABLE IF NOT EXISTS sessions (
    session_hash TEXT PRIMARY KEY,
    token_hash TEXT NOT NULL,
    created_at REAL NOT NULL,
    expires_at REAL NOT NULL
);
"""


def _digest(secret: str) -> str:
    return hashlib.sha256(secret.encode()).hexdigest()


class SessionBook:
    """Sessions in the state store, with the ones seen cached until they end."""

    def __init__(self, state: StateStore, ttl_s: float = SESSION_TTL_S) -> None:
        self.state = state
        self.ttl_s = ttl_s
        self._cache: dict[str, tuple[str, str, float]] = {}
        self._ready = False

    async def _schema(self) -> None:
        if not self._ready:
            await self.state.script(_SCHEMA)
            self._ready = True

    async def open(self, token_hash: str) -> str:
        """A new session for the token whose hash is ``token_hash``; the cookie's value."""
        await self._schema()
        session = secrets.token_urlsafe(32)
        now = time.time()
        await self.state.write(
            ("DELETE FROM sessions WHERE expires_at < ?", (now,)),
            (
                "INSERT INTO sessions (session_hash, token_hash, created_at, expires_at) "
                "VALUES (?, ?, ?, ?)",
                (_digest(session), token_hash, now, now + self.ttl_s),
            ),
        )
        return session

    async def find(self, session: str) -> tuple[str, str] | None:
        """The (token name, role) of a live session, None for an unknown or ended one."""
        digest = _digest(session)
        cached = self._cache.get(digest)
        if cached is None:
            await self._schema()
            rows = await self.state.rows(
                "SELECT t.name, t.role, s.expires_at FROM sessions s "
                "JOIN tokens t ON t.token_hash = s.token_hash WHERE s.session_hash = ?",
                (digest,),
            )
            if not rows:
                return None
            cached = (rows[0][0], rows[0][1], float(rows[0][2]))
            self._cache[digest] = cached
        name, role, expires_at = cached
        if time.time() >= expires_at:
            self._cache.pop(digest, None)
            return None
        return name, role

    async def close(self, session: str) -> None:
        """Sign out: the session is gone from the store and the cache."""
        await self._schema()
        digest = _digest(session)
        self._cache.pop(digest, None)
        await self.state.write(("DELETE FROM sessions WHERE session_hash = ?", (digest,)))

    def forget(self) -> None:
        """Drop the cache (a token was revoked or replaced: its sessions are re-checked)."""
        self._cache.clear()
