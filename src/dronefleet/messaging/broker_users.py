"""Who may connect to a broker: a drone or a ground service, each with its own password.

Passwords are random (24 bytes), handed out once, and kept only as Mosquitto's own hash
(``$7$<iterations>$<salt>$<key>``: PBKDF2-HMAC-SHA512, base64; the format ``mosquitto_passwd``
writes), so the same record serves the in-process bus (messaging/local_bus.py) and a
Mosquitto password file (messaging/broker_acl.py) alike. Checked in constant time. Beside it, the
same password as RabbitMQ's hash (messaging/rabbit_acl.py) and as bcrypt, the one hash NATS reads
(messaging/nats_config.py): no broker's configuration ever holds a password itself.
"""

from __future__ import annotations

import base64
import hashlib
import hmac
import os
import secrets
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from enum import StrEnum

import bcrypt

from dronefleet.errors import InvalidInput
from dronefleet.messaging.topics import GROUND_PREFIX, check_drone_id

#: PBKDF2 rounds; Mosquitto reads the count from each hash, so any value works with it.
ITERATIONS = 1_000
_SALT_BYTES = 12
#: bcrypt costs (2**cost rounds) of the NATS hash. NATS checks it at every CONNECT, in the server,
#: so the cost is paid per connection (bench/broker_capacity.py, 1000 drones): at cost 10 the
#: server spent 58 s of CPU connecting them and dropped 153 that waited too long; at cost 4,
#: 1.2 s, all connected in 0.8 s. Making the hashes costs as much again here (60 ms a user at
#: 10). A generated password is 24 random bytes (192 bits), which no work factor needs to
#: protect against guessing (the same reasoning as ITERATIONS): bcrypt's minimum. A password
#: someone chose may be guessable, so it gets the usual cost.
NATS_COST_GENERATED = 4
NATS_COST_CHOSEN = 10
#: bcrypt reads at most 72 bytes of a password; a longer one gets no NATS hash.
BCRYPT_MAX_BYTES = 72


class BrokerRole(StrEnum):
    DRONE = "drone"  # speaks only under its own id
    GROUND = "ground"  # commands any drone, hears every drone, owns ``ground/...``


@dataclass(frozen=True)
class BrokerUser:
    name: str  # a drone's user name is its drone id
    role: BrokerRole
    password_hash: str
    rabbit_hash: str | None = None  # RabbitMQ's form of the same password (rabbit_acl.py)
    nats_hash: str | None = None  # bcrypt, for NATS (nats_config.py)


def hash_password(password: str, *, salt: bytes | None = None) -> str:
    salt = salt if salt is not None else secrets.token_bytes(_SALT_BYTES)
    key = hashlib.pbkdf2_hmac("sha512", password.encode(), salt, ITERATIONS)
    b64 = base64.b64encode
    return f"$7${ITERATIONS}${b64(salt).decode()}${b64(key).decode()}"


def rabbit_hash(password: str, *, salt: bytes | None = None) -> str:
    """RabbitMQ's ``rabbit_password_hashing_sha256``: base64(salt + SHA-256(salt + password)),
    a 32-bit salt (RabbitMQ's "Credentials and Passwords" guide), for its definitions file."""
    salt = salt if salt is not None else secrets.token_bytes(4)
    return base64.b64encode(salt + hashlib.sha256(salt + password.encode()).digest()).decode()


def nats_hash(password: str, *, cost: int = NATS_COST_CHOSEN) -> str:
    """bcrypt (``$2b$<cost>$...``), which NATS accepts in place of a password in its
    configuration."""
    return bcrypt.hashpw(password.encode(), bcrypt.gensalt(cost)).decode()


def check_password(password: str, hashed: str) -> bool:
    try:
        _, kind, rounds, salt, key = hashed.split("$")
        if kind != "7":
            return False
        got = hashlib.pbkdf2_hmac("sha512", password.encode(), base64.b64decode(salt), int(rounds))
    except (ValueError, TypeError):
        return False
    return hmac.compare_digest(got, base64.b64decode(key))


def new_password() -> str:
    return secrets.token_urlsafe(24)


def _check_name(name: str, role: BrokerRole) -> None:
    if role is BrokerRole.DRONE:
        check_drone_id(name)
    elif not name or ":" in name or name.startswith(GROUND_PREFIX + "/"):
        raise InvalidInput(f"bad broker user name {name!r}")


def _hashed_user(name: str, role: BrokerRole, password: str | None) -> tuple[BrokerUser, str]:
    """The user record (hashes only) and its password, a fresh one unless given."""
    cost = NATS_COST_CHOSEN if password else NATS_COST_GENERATED
    password = password or new_password()
    fits = len(password.encode()) <= BCRYPT_MAX_BYTES
    nats = nats_hash(password, cost=cost) if fits else None
    return BrokerUser(name, role, hash_password(password), rabbit_hash(password), nats), password


class BrokerUsers:
    """The users of one broker, by name."""

    def __init__(self) -> None:
        self._users: dict[str, BrokerUser] = {}

    def add(self, name: str, role: BrokerRole, password: str | None = None) -> str:
        """Create or replace ``name``; returns its password (the only time it is seen)."""
        _check_name(name, role)
        user, password = _hashed_user(name, role, password)
        self._users[name] = user
        return password

    def add_many(self, names: Sequence[str], role: BrokerRole) -> list[str]:
        """:meth:`add` for each of ``names`` (fresh passwords), returned in the same order. The
        hashes are made on a few threads (bcrypt and PBKDF2 let go of the GIL): a thousand
        drones' users took 2.2 s one by one, of a simulated fleet's start-up
        (bench/sim_scale.py). All names are checked before any user is made."""
        for name in names:
            _check_name(name, role)
        threads = min(4, os.cpu_count() or 1, len(names))
        if threads <= 1:  # one user (url_for), or one CPU: no pool to start
            made = [_hashed_user(name, role, None) for name in names]
        else:
            with ThreadPoolExecutor(threads, thread_name_prefix="broker-users") as pool:
                made = list(pool.map(lambda name: _hashed_user(name, role, None), names))
        for user, _ in made:
            self._users[user.name] = user
        return [password for _, password in made]

    def add_hashed(self, user: BrokerUser) -> None:
        self._users[user.name] = user

    def remove(self, name: str) -> bool:
        return self._users.pop(name, None) is not None

    def get(self, name: str | None) -> BrokerUser | None:
        return self._users.get(name) if name else None

    def all(self) -> list[BrokerUser]:
        return sorted(self._users.values(), key=lambda u: u.name)

    def authenticate(self, name: str | None, password: str | None) -> BrokerUser | None:
        user = self.get(name)
        if user is None or password is None or not check_password(password, user.password_hash):
            return None
        return user
