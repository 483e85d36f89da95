"""Many broker users made at once (``BrokerUsers.add_many``): the same records as one by one,
hashed on a few threads, all names checked first."""

from __future__ import annotations

import bcrypt
import pytest

from dronefleet.errors import InvalidInput
from dronefleet.messaging.broker_users import (
    NATS_COST_GENERATED,
    BrokerRole,
    BrokerUsers,
    check_password,
)


def test_each_user_gets_its_own_password_in_the_order_asked():
    users = BrokerUsers()
    names = [f"QUAD_{i}" for i in range(1, 21)]
    passwords = users.add_many(names, BrokerRole.DRONE)
    assert len(set(passwords)) == len(names)
    assert [u.name for u in users.all()] == sorted(names)
    for name, password in zip(names, passwords, strict=True):
        assert users.authenticate(name, password) is not None
        user = users.get(name)
        assert user.role is BrokerRole.DRONE and check_password(password, user.password_hash)
        assert user.nats_hash.startswith(f"$2b${NATS_COST_GENERATED:02d}$")
        assert bcrypt.checkpw(password.encode(), user.nats_hash.encode())
        assert user.rabbit_hash
    assert users.authenticate("QUAD_1", passwords[1]) is None  # another's password


def test_a_bad_name_makes_none_of_them():
    users = BrokerUsers()
    with pytest.raises(InvalidInput):
        users.add_many(["QUAD_1", "ground/x"], BrokerRole.GROUND)
    with pytest.raises(InvalidInput):
        users.add_many(["QUAD_1", "bad id!"], BrokerRole.DRONE)
    assert users.all() == []
    assert users.add_many([], BrokerRole.DRONE) == []
