"""The embedded broker's authentication and topic rules (issue 12).

amqtt's own plugins check a password file in passlib's formats and a static ACL per user name;
the fleet's rules depend on the user's role and name (a drone only under its own id), so a small
auth plugin checks the users of messaging/broker_users.py (the same records a Mosquitto password
file is written from) and :func:`topic_rule` applies messaging/broker_acl.py. Anonymous clients
are refused unless the broker was started with ``anonymous=True`` (tests that ask for it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from amqtt.contexts import Action
from amqtt.plugins.base import BaseAuthPlugin
from amqtt.session import Session

from dronefleet.messaging.broker_acl import may_publish, may_subscribe
from dronefleet.messaging.broker_users import BrokerUsers


class FleetAuthPlugin(BaseAuthPlugin):
    @dataclass
    class Config:
        users: Any = None  # BrokerUsers, read live (dacite passes Any through as is)
        anonymous: bool = False

    async def authenticate(self, *, session: Session) -> bool | None:
        users: BrokerUsers = self.config.users
        if session.username is None and self.config.anonymous:
            return True
        return users.authenticate(session.username, session.password) is not None


def topic_rule(users: BrokerUsers, anonymous: bool) -> Callable[[str | None, str, Action], bool]:
    """What ``user`` may do with ``topic`` (messaging/broker_acl.py), for the embedded broker's
    own topic check (messaging/broker_index.py): an anonymous client (when allowed) anything."""

    def allowed(name: str | None, topic: str, action: Action) -> bool:
        user = users.get(name)
        if user is None:
            return anonymous and name is None
        if action is Action.PUBLISH:
            return may_publish(user, topic)
        return may_subscribe(user, topic)

    return allowed
