"""The RabbitMQ form of the broker rules (messaging/rabbit_acl.py) and its password hash."""

from __future__ import annotations

import re

import pytest

from dronefleet.errors import InvalidInput
from dronefleet.messaging.broker_users import BrokerRole, BrokerUser, BrokerUsers, rabbit_hash
from dronefleet.messaging.rabbit_acl import rabbit_login, rabbitmq_definitions


def test_the_hash_is_rabbitmqs_sha256_form() -> None:
    # The worked example of RabbitMQ's "Credentials and Passwords" guide.
    salt = bytes.fromhex("908DC60A")
    assert rabbit_hash("test12", salt=salt) == "kI3GCqW5JLMJa4iX1lo7X4D6XbYqlLgxIs30+P6tENUV2POR"


def test_each_user_gets_only_its_own_routing_keys() -> None:
    users = BrokerUsers()
    users.add("QUAD_1", BrokerRole.DRONE)
    users.add("ground", BrokerRole.GROUND)
    defs = rabbitmq_definitions(users, "fleet")
    topics = {t["user"]: t for t in defs["topic_permissions"]}
    drone, ground = topics["QUAD_1"], topics["ground"]

    def ok(pattern: str, key: str) -> bool:
        return re.fullmatch(pattern, key) is not None

    assert ok(drone["write"], "QUAD_1.telemetry.out") and ok(drone["read"], "QUAD_1.control.in")
    # A takepic: the controller asks its Gear Manager and hears the answer; its Logger hears all.
    assert ok(drone["write"], "QUAD_1.gear.in") and ok(drone["read"], "QUAD_1.gear.out")
    assert ok(drone["read"], "QUAD_1.#") and ok(drone["read"], "QUAD_1.*.in")
    assert not ok(drone["write"], "QUAD_1.control.in")  # no commands to itself
    assert not ok(drone["read"], "QUAD_2.gear.out") and not ok(drone["write"], "QUAD_2.gear.in")
    assert not ok(drone["write"], "QUAD_2.control.in") and not ok(drone["read"], "QUAD_2.gear.in")
    assert not ok(drone["write"], "QUAD_10.control.in")  # not a prefix match
    assert ok(ground["write"], "QUAD_2.control.in") and ok(ground["read"], "*.heartbeats.out")
    assert not ok(ground["write"], "QUAD_2.telemetry.out")  # it cannot speak for a drone
    assert ok(ground["read"], "ground.identifier.events")
    assert {u["hashing_algorithm"] for u in defs["users"]} == {"rabbit_password_hashing_sha256"}
    assert defs["vhosts"] == [{"name": "fleet"}]


def test_users_without_a_rabbitmq_hash_are_named() -> None:
    users = BrokerUsers()
    users.add_hashed(BrokerUser("QUAD_OLD", BrokerRole.DRONE, "$7$1$x$y"))
    with pytest.raises(InvalidInput, match="QUAD_OLD"):
        rabbitmq_definitions(users, "fleet")


def test_a_vhost_with_a_colon_is_refused_and_logins_are_vhost_colon_user() -> None:
    users = BrokerUsers()
    users.add("QUAD_1", BrokerRole.DRONE)
    assert rabbit_login("fleet", "QUAD_1") == "fleet:QUAD_1"
    with pytest.raises(InvalidInput, match="':'"):
        rabbitmq_definitions(users, "fleet:a")
