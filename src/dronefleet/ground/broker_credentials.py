"""The fleet's broker users, kept in the ground state store (issue 12): hashes only.

``dronefleet credentials add-drone QUAD_1`` makes a drone's user (a fresh password, shown once
or written to a 0600 file for the drone), ``add-ground`` a ground service's, ``revoke`` removes
one; ``dronefleet broker-config`` writes the Mosquitto password and ACL files from them
(messaging/broker_acl.py). The hashes are Mosquitto's own format, so nothing is converted.
"""

from __future__ import annotations

from dronefleet.clock import timestamp_s
from dronefleet.ground.state import StateStore
from dronefleet.messaging.broker_users import BrokerRole, BrokerUser, BrokerUsers, new_password

_SCHEMA = """
CREATE TABLE IF NOT EXISTS broker_users (
    name TEXT PRIMARY KEY,
    role TEXT NOT NULL,
    password_hash TEXT NOT NULL,
    created_at REAL NOT NULL
);
"""
#: Added later: RabbitMQ's hash of the same password (users made before have none).
_RABBIT_COLUMN = "ALTER TABLE broker_users ADD COLUMN rabbit_hash TEXT"


class BrokerCredentials:
    def __init__(self, state: StateStore) -> None:
        self.state = state

    async def open(self) -> BrokerCredentials:
        await self.state.script(_SCHEMA)
        if "rabbit_hash" not in await self.state.columns("broker_users"):
            await self.state.write((_RABBIT_COLUMN, ()))
        return self

    async def add(self, name: str, role: BrokerRole, password: str | None = None) -> str:
        """Create or replace ``name``; its password (the only time it is seen)."""
        users = BrokerUsers()
        password = users.add(name, role, password or new_password())  # checks the name
        user = users.all()[0]
        await self.state.write(
            (
                "INSERT INTO broker_users (name, role, password_hash, created_at, rabbit_hash) "
                "VALUES (?, ?, ?, ?, ?) ON CONFLICT(name) DO UPDATE SET role=excluded.role, "
                "password_hash=excluded.password_hash, created_at=excluded.created_at, "
                "rabbit_hash=excluded.rabbit_hash",
                (user.name, user.role.value, user.password_hash, timestamp_s(), user.rabbit_hash),
            )
        )
        return password

    async def revoke(self, name: str) -> bool:
        (removed,) = await self.state.write(("DELETE FROM broker_users WHERE name = ?", (name,)))
        return removed > 0

    async def users(self) -> BrokerUsers:
        users = BrokerUsers()
        for name, role, hashed, rabbit in await self.state.rows(
            "SELECT name, role, password_hash, rabbit_hash FROM broker_users ORDER BY name"
        ):
            users.add_hashed(BrokerUser(name, BrokerRole(role), hashed, rabbit))
        return users
