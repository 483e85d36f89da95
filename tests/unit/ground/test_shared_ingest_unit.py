"""Shared telemetry ingestion without a server (ground/telemetry/shared_ingest.py, issue 27): its
address, subjects back to topics, the ground's permission to take the queue group, refusals."""

from __future__ import annotations

import orjson
import pytest

from dronefleet.cli import build_parser
from dronefleet.ground.telemetry.shared_ingest import (
    OPTION,
    SUBJECT,
    IngestionNotShared,
    SharedIngest,
)
from dronefleet.messaging.broker_users import BrokerRole, BrokerUser
from dronefleet.messaging.nats_config import mqtt_topic, nats_subject, permissions
from dronefleet.messaging.nats_link import nats_servers
from dronefleet.messaging.status import Telemetry
from dronefleet.messaging.url import BrokerUrl

GROUND = BrokerUrl("127.0.0.1", 1883, username="ground", password="secret")


def test_the_nats_address_is_one_or_more_nodes_and_nothing_else():
    assert nats_servers("nats://a:4222,b:4223", OPTION) == ["nats://a:4222", "nats://b:4223"]
    for wrong in ("mqtt://a:1883", "a:4222", "nats://", "http://a", "tls://a:4222"):
        with pytest.raises(IngestionNotShared):
            nats_servers(wrong, OPTION)
    with pytest.raises(SystemExit):
        build_parser().parse_args(["ground", "--share-ingestion", "mqtt://a:1883"])
    args = build_parser().parse_args(["ground", "--share-ingestion", "nats://a:4222"])
    assert args.share_ingestion == "nats://a:4222"


@pytest.mark.parametrize("topic", ["QUAD_1/telemetry/out", "drone.7/telemetry/out"])
def test_a_subject_is_its_topic_again(topic):
    assert mqtt_topic(nats_subject(topic)[0]) == topic


def test_the_ground_user_may_subscribe_the_shared_subject():
    subscribe = permissions(BrokerUser("ground", BrokerRole.GROUND, "")).subscribe
    assert SUBJECT == "*.telemetry.out" and "*.*.out" in subscribe
    drone = permissions(BrokerUser("QUAD_1", BrokerRole.DRONE, "")).subscribe
    assert "*.*.out" not in drone and SUBJECT not in drone


def test_an_in_process_bus_or_no_credentials_is_refused():
    with pytest.raises(IngestionNotShared, match="in-process bus"):
        SharedIngest("nats://a:4222", BrokerUrl.parse("local://g:p@bus"), take=print, name="x")
    with pytest.raises(IngestionNotShared, match="never anonymously"):
        SharedIngest("nats://a:4222", BrokerUrl("a"), take=print, name="x")


def test_messages_are_read_as_the_inbox_reads_them():
    taken: list[Telemetry] = []
    ingest = SharedIngest("nats://a:4222", GROUND, take=taken.append, name="x")
    good = {"drone_id": "QUAD_1", "vehicle_time_s": 1.0, "fields": {"lat": 1.0}, "new": 1}
    ingest.receive("QUAD_1/telemetry/out", orjson.dumps(good))  # an unknown field is ignored
    ingest.receive("QUAD_2/telemetry/out", orjson.dumps(good))  # QUAD_1's on QUAD_2's topic
    ingest.receive("QUAD_1/telemetry/out", b"\xff")
    ingest.receive("QUAD_1/telemetry/out", orjson.dumps({**good, "vehicle_time_s": "x"}))
    assert [m.drone_id for m in taken] == ["QUAD_1"] and ingest.received == 1
    assert ingest.dropped == {
        "malformed telemetry": 2,
        "telemetry on another drone's topic": 1,
    }


def test_the_ground_refuses_the_option_on_an_in_process_bus_before_starting(tmp_path, capsys):
    from dronefleet.cli import main

    code = main([
        "ground", "--broker", "local://ground:pw@bus-x", "--state", str(tmp_path / "g.db"),
        "--store", f"sqlite:///{tmp_path}/t.db", "--http", "127.0.0.1:0",
        "--share-ingestion", "nats://127.0.0.1:4222",
    ])  # fmt: skip
    assert code == 2
    assert "in-process bus" in capsys.readouterr().err
    assert not (tmp_path / "g.db").exists()  # nothing started


async def test_a_refusal_by_the_server_is_the_reason_given_even_if_a_reset_came_after():
    # NATS closes the socket on a wrong password: the next try may only see the reset (CI, stop 33).
    ingest = SharedIngest("nats://127.0.0.1:4222", GROUND, take=print, name="x")
    await ingest.link._error(Exception("nats: 'Authorization Violation'"))
    await ingest.link._error(ConnectionResetError(104, "Connection reset by peer"))
    assert "Authorization" in str(ingest.link._last_error)
    fresh = SharedIngest("nats://127.0.0.1:4222", GROUND, take=print, name="y")
    await fresh.link._error(TimeoutError())
    await fresh.link._error(ConnectionResetError(104, "Connection reset by peer"))
    assert isinstance(fresh.link._last_error, ConnectionResetError)
