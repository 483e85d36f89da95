"""The broker rules as NATS permissions (messaging/nats_config.py, issue 25)."""

import bcrypt
import pytest

from dronefleet.errors import InvalidInput
from dronefleet.messaging.broker_acl import may_publish, may_subscribe, mosquitto_files
from dronefleet.messaging.broker_users import (
    NATS_COST_CHOSEN,
    NATS_COST_GENERATED,
    BrokerRole,
    BrokerUser,
    BrokerUsers,
)
from dronefleet.messaging.nats_broker import NatsBroker
from dronefleet.messaging.nats_config import (
    ANONYMOUS_USER,
    LOCKED_USER,
    NatsCluster,
    nats_config,
    nats_subject,
    permissions,
)

GROUND = BrokerUser("ground", BrokerRole.GROUND, "")
QUAD_1 = BrokerUser("QUAD_1", BrokerRole.DRONE, "")


def _covers(allowed: str, subject: str) -> bool:
    """Whether NATS's ``allowed`` subject covers ``subject`` (itself possibly with wildcards, as
    a subscription's): ``*`` one token, ``>`` one or more."""
    want, have = allowed.split("."), subject.split(".")
    for i, token in enumerate(want):
        if token == ">":
            return len(have) > i
        if i >= len(have) or (token != have[i] and not (token == "*" and have[i] != ">")):
            return False
    return len(want) == len(have)


def nats_allows(subjects: tuple[str, ...], mqtt: str) -> bool:
    """NATS's check of an MQTT topic or filter: every subject it stands for is allowed."""
    return all(any(_covers(a, s) for a in subjects) for s in nats_subject(mqtt))


@pytest.mark.parametrize(
    ("mqtt", "subjects"),
    [
        ("QUAD_1/control/in", ["QUAD_1.control.in"]),
        ("+/+/out", ["*.*.out"]),
        ("QUAD_1/#", ["QUAD_1", "QUAD_1.>"]),  # MQTT's '#' matches its parent level too
        ("#", [">"]),
        ("a.b/c", ["a//b.c"]),
    ],
)
def test_mqtt_topics_map_to_nats_subjects(mqtt, subjects):
    assert nats_subject(mqtt) == subjects


TOPICS = [
    "QUAD_1/control/in", "QUAD_1/telemetry/out", "QUAD_1/gear/in", "QUAD_1/gear/out",
    "QUAD_1/mission/out", "QUAD_1/heartbeats/out", "QUAD_2/control/in", "QUAD_2/alarms/out",
    "ground/presence", "ground/planner/events", "ground", "other/thing",
]  # fmt: skip
FILTERS = [
    "+/telemetry/out", "+/+/out", "+/control/in", "#", "QUAD_1/#", "QUAD_1/+/in",
    "QUAD_1/telemetry/out", "QUAD_2/control/in", "+/control/out", "ground/#", "QUAD_1/control/in",
]  # fmt: skip


@pytest.mark.parametrize("shared", [True, False])
@pytest.mark.parametrize("user", [GROUND, QUAD_1], ids=["ground", "QUAD_1"])
def test_each_rule_of_broker_acl_holds_as_nats_permissions(user, shared):
    perms = permissions(user, shared=shared)
    for topic_name in TOPICS:
        want = may_publish(user, topic_name, shared=shared)
        assert nats_allows(perms.publish, topic_name) is want, ("publish", topic_name)
    for topic_filter in FILTERS:
        want = may_subscribe(user, topic_filter, shared=shared)
        assert nats_allows(perms.subscribe, topic_filter) is want, ("subscribe", topic_filter)


def test_where_nats_says_more_than_broker_acl():
    """NATS cannot say "a channel or +": the ground's ``*.*.out`` also covers a channel that
    does not exist (only a drone can publish there); a drone may subscribe to its bare id, which
    ``<id>/#`` needs and nobody may publish to."""
    assert not may_subscribe(GROUND, "QUAD_1/nochannel/out")
    assert nats_allows(permissions(GROUND).subscribe, "QUAD_1/nochannel/out")
    assert not nats_allows(permissions(GROUND).publish, "QUAD_1/nochannel/in")
    drone = permissions(QUAD_1)
    assert "QUAD_1" in drone.subscribe and "QUAD_1" not in drone.publish


def test_a_drone_on_the_grounds_broker_has_what_mosquitto_gives_it():
    users = BrokerUsers()
    users.add_hashed(QUAD_1)
    _, acl = mosquitto_files(users)
    perms = permissions(QUAD_1, shared=False)
    for line in acl.splitlines():
        if line.startswith("topic "):
            _, mode, pattern = line.split()
            if "write" in mode:
                assert nats_allows(perms.publish, pattern), line
            if "read" in mode:
                assert nats_allows(perms.subscribe, pattern), line


def test_the_config_holds_hashes_never_passwords():
    users = BrokerUsers()
    ground_password = users.add("ground", BrokerRole.GROUND)
    quad_password = users.add("QUAD_1", BrokerRole.DRONE)
    text = nats_config(users, mqtt_host="127.0.0.1", mqtt_port=1884, store_dir="/tmp/js")
    assert ground_password not in text and quad_password not in text
    for user, password in [("ground", ground_password), ("QUAD_1", quad_password)]:
        hashed = users.get(user).nats_hash
        assert f'password: "{hashed}"' in text
        assert bcrypt.checkpw(password.encode(), hashed.encode())
    assert 'listen: "127.0.0.1:1884"' in text and 'ack_wait: "2s"' in text
    assert 'store_dir: "/tmp/js"' in text and "no_auth_user" not in text
    assert '{user: "QUAD_1", password:' in text
    assert 'publish: {allow: ["QUAD_1.>"]}' in text
    assert 'subscribe: {allow: ["*.*.out", "ground", "ground.>"]}' in text


def test_generated_passwords_get_bcrypts_minimum_cost_and_chosen_ones_more():
    users = BrokerUsers()
    users.add("QUAD_1", BrokerRole.DRONE)
    users.add("QUAD_2", BrokerRole.DRONE, "a password someone chose")
    users.add("QUAD_3", BrokerRole.DRONE, "x" * 73)  # beyond what bcrypt reads
    assert users.get("QUAD_1").nats_hash.startswith(f"$2b${NATS_COST_GENERATED:02d}$")
    assert users.get("QUAD_2").nats_hash.startswith(f"$2b${NATS_COST_CHOSEN:02d}$")
    assert users.get("QUAD_3").nats_hash is None
    with pytest.raises(InvalidInput, match="QUAD_3"):
        nats_config(users, mqtt_host="127.0.0.1", mqtt_port=1884, store_dir="/tmp/js")


def test_users_without_a_nats_hash_are_refused_by_name():
    users = BrokerUsers()
    users.add_hashed(BrokerUser("QUAD_OLD", BrokerRole.DRONE, "$7$1$x$y", "r"))
    with pytest.raises(InvalidInput, match="QUAD_OLD"):
        nats_config(users, mqtt_host="127.0.0.1", mqtt_port=1884, store_dir="/tmp/js")


def test_anonymous_clients_become_a_user_allowed_everything_only_when_asked():
    users = BrokerUsers()
    users.add("QUAD_1", BrokerRole.DRONE)
    text = nats_config(users, mqtt_host="h", mqtt_port=1, store_dir="/s", anonymous=True)
    assert f'no_auth_user: "{ANONYMOUS_USER}"' in text
    assert f'{{user: "{ANONYMOUS_USER}", permissions:' in text  # no password: none is asked
    assert 'publish: {allow: [">"]}' in text


def test_a_broker_with_no_users_yet_still_asks_for_credentials():
    """NATS with no users would let anyone in: a locked user keeps authentication on."""
    text = nats_config(BrokerUsers(), mqtt_host="h", mqtt_port=1, store_dir="/s")
    assert f'{{user: "{LOCKED_USER}", password: "$2a$10$' in text
    assert 'publish: {deny: [">"]}' in text and 'subscribe: {deny: [">"]}' in text
    anonymous = nats_config(BrokerUsers(), mqtt_host="h", mqtt_port=1, store_dir="/s",
                            anonymous=True)  # fmt: skip
    assert LOCKED_USER not in anonymous


def test_a_cluster_node_names_itself_its_routes_and_the_replicas():
    node = NatsCluster(
        "fleet", "n1", "10.0.0.1", 6222, ("nats-route://10.0.0.2:6222",), stream_replicas=3
    )
    users = BrokerUsers()
    users.add("ground", BrokerRole.GROUND)
    text = nats_config(users, mqtt_host="0.0.0.0", mqtt_port=1883, store_dir="/s", cluster=node)
    assert 'server_name: "n1"' in text and "stream_replicas: 3" in text
    assert 'cluster {\n  name: "fleet"\n  listen: "10.0.0.1:6222"' in text
    assert 'routes: ["nats-route://10.0.0.2:6222"]' in text


def test_consumers_in_memory_only_when_asked_as_the_embedded_broker_does(tmp_path):
    """Its store is temporary, so its QoS 1 subscriptions' consumers are kept in memory (several
    times cheaper to make); a cluster node's, and any other, stay on disk."""
    users = BrokerUsers()
    users.add("QUAD_1", BrokerRole.DRONE)
    default = nats_config(users, mqtt_host="h", mqtt_port=1, store_dir="/s")
    assert "consumer_memory_storage" not in default
    asked = nats_config(users, mqtt_host="h", mqtt_port=1, store_dir="/s", consumer_memory=True)
    mqtt_block = asked[asked.index("mqtt {") :]
    assert "  consumer_memory_storage: true\n" in mqtt_block
    embedded = NatsBroker(users=users)
    embedded._write_config(tmp_path)
    assert "consumer_memory_storage: true" in (tmp_path / "nats.conf").read_text()
