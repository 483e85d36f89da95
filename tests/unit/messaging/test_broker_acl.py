"""The fleet's broker rules (messaging/broker_acl.py, issue 12)."""

import pytest

from dronefleet.messaging.broker_acl import (
    drone_rights,
    may_publish,
    may_subscribe,
    mosquitto_files,
)
from dronefleet.messaging.broker_users import (
    BrokerRole,
    BrokerUser,
    BrokerUsers,
    check_password,
    hash_password,
)

GROUND = BrokerUser("ground", BrokerRole.GROUND, "")
QUAD_1 = BrokerUser("QUAD_1", BrokerRole.DRONE, "")


@pytest.mark.parametrize(
    ("user", "topic", "shared", "ok"),
    [
        (GROUND, "QUAD_1/control/in", True, True),
        (GROUND, "QUAD_1/alarms/out", True, False),  # the ground cannot speak for a drone
        (GROUND, "ground/planner/events", True, True),
        (GROUND, "+/control/in", True, False),
        (QUAD_1, "QUAD_1/alarms/out", False, True),
        (QUAD_1, "QUAD_1/control/in", False, False),  # on the ground's broker: out only,
        (QUAD_1, "QUAD_1/gear/in", False, True),  # and its controller asking its own gear
        (QUAD_1, "QUAD_2/gear/in", False, False),
        (QUAD_1, "QUAD_1/gear/out/x", False, False),
        (QUAD_1, "QUAD_1/gear/in", True, True),  # on a shared broker its parts talk
        (QUAD_1, "QUAD_2/control/in", True, False),
        (QUAD_1, "ground/presence/x", True, False),
    ],
)
def test_who_may_publish(user, topic, shared, ok):
    assert may_publish(user, topic, shared=shared) is ok


@pytest.mark.parametrize(
    ("user", "topic_filter", "shared", "ok"),
    [
        (GROUND, "+/telemetry/out", True, True),
        (GROUND, "+/+/out", True, True),
        (GROUND, "+/control/in", True, False),  # no listening to other clients' commands
        (GROUND, "#", True, False),
        (QUAD_1, "QUAD_1/+/in", False, True),
        (QUAD_1, "QUAD_1/gear/out", False, True),  # its Gear Manager's answers (a takepic)
        (QUAD_1, "QUAD_1/mission/out", False, True),  # its fail-safe follows its progress
        (QUAD_1, "QUAD_1/#", False, True),  # its Logger
        (QUAD_1, "QUAD_2/gear/out", False, False),
        (QUAD_1, "+/gear/out", False, False),
        (QUAD_1, "#", False, False),
        (QUAD_1, "+/control/in", True, False),
        (QUAD_1, "#", True, False),
    ],
)
def test_who_may_subscribe(user, topic_filter, shared, ok):
    assert may_subscribe(user, topic_filter, shared=shared) is ok


def test_passwords_are_kept_as_mosquitto_hashes_and_checked():
    hashed = hash_password("s3cret")
    assert hashed.startswith("$7$") and "s3cret" not in hashed
    assert check_password("s3cret", hashed) and not check_password("S3cret", hashed)
    assert not check_password("s3cret", "$6$garbage") and not check_password("x", "nonsense")
    users = BrokerUsers()
    password = users.add("QUAD_1", BrokerRole.DRONE)
    assert users.authenticate("QUAD_1", password) is not None
    assert users.authenticate("QUAD_1", None) is None and users.authenticate(None, None) is None
    with pytest.raises(ValueError):
        users.add("<img>", BrokerRole.DRONE)


def test_the_mosquitto_acl_gives_a_drone_what_its_parts_use_under_its_id_only():
    users = BrokerUsers()
    users.add("QUAD_1", BrokerRole.DRONE)
    _, acl = mosquitto_files(users)
    rules = acl.split("user QUAD_1\n", 1)[1].strip().splitlines()
    assert rules == [
        "topic write QUAD_1/+/out",
        "topic write QUAD_1/gear/in",
        "topic read QUAD_1/#",
    ]
    publish, subscribe = drone_rights("QUAD_1")
    assert [f"topic write {p}" for p in publish] + [f"topic read {p}" for p in subscribe] == rules
