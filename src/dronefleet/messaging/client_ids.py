"""The client id a broker client goes on the wire with: never one another client could guess."""

from __future__ import annotations

import hashlib
import hmac
import secrets

from dronefleet.messaging.url import BrokerUrl


def unguessable_id(base: str, url: BrokerUrl, *, persistent: bool) -> str:
    """The client id ``base`` goes on the wire as: ``base-<20 hex>`` (issue 25).

    Under MQTT 3.1.1 any client the broker lets in may take over a connection, and resume its
    session, by connecting with its client id; a stolen drone's credentials then disconnected or
    deafened the ground's planner, whose id was the fixed ``ground-planner``. So no id can be
    guessed: a random tail for a clean session, and for a persistent one (which must find its
    session again after a restart) an HMAC of ``base`` keyed with the client's own password, the
    same at every start and known only to who holds that password. An anonymous client (only on
    test brokers that allow anonymity) has no secret and keeps ``base`` for a persistent session.
    """
    if not persistent:
        return f"{base}-{secrets.token_hex(10)}"
    if not url.password:
        return base
    tag = hmac.new(url.password.encode(), base.encode(), hashlib.sha256).hexdigest()[:20]
    return f"{base}-{tag}"
