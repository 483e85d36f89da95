"""The seed's topics (Table 4.4) come from one helper and parse back."""

import asyncio

import pytest

from dronefleet.messaging import topics
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.topics import Channel, Direction, TopicError


def test_table_4_4_topics():
    assert (
        topics.topic("REVOLUTION_94E041", Channel.CONTROL, Direction.IN)
        == "REVOLUTION_94E041/control/in"
    )
    assert topics.topic("R", Channel.TELEMETRY, Direction.OUT) == "R/telemetry/out"
    assert topics.any_drone(Channel.HEARTBEATS) == "+/heartbeats/out"
    assert topics.drone_all("R") == "R/#"
    assert topics.ground("identifier", "in") == "ground/identifier/in"


def test_out_only_channels_have_no_in_topic():
    with pytest.raises(TopicError):
        topics.topic("R", Channel.HEARTBEATS, Direction.IN)


@pytest.mark.parametrize(
    "bad", ["", "a/b", "+", "#", "ground", "x" * 65, "sp ace", "QUAD.3", "Q_1\n", "Q:1"]
)
def test_drone_ids_never_contain_wildcards_or_separators(bad):
    """Nor '.': RabbitMQ's MQTT adapter takes it for a level separator (``QUAD.3/telemetry/out``
    is routed as ``QUAD/3/telemetry/out``) and NATS refuses it in a client id."""
    with pytest.raises(TopicError, match="letters, digits, '_' or '-'"):
        topics.topic(bad, Channel.CONTROL, Direction.IN)


def test_parse_round_trips():
    parsed = topics.parse("QUAD_1/mission/out")
    assert (parsed.drone_id, parsed.channel, parsed.direction) == (
        "QUAD_1",
        Channel.MISSION,
        Direction.OUT,
    )
    with pytest.raises(TopicError):
        topics.parse("QUAD_1/nope/out")


@pytest.mark.parametrize(
    ("pattern", "topic_name", "expected"),
    [
        ("+/control/out", "Q/control/out", True),
        ("+/control/out", "Q/control/in", False),
        ("Q/#", "Q/a/b", True),
        ("Q/#", "R/a", False),
        ("a/+", "a/b/c", False),
        ("a/b", "a/b", True),
    ],
)
async def test_filter_matching(pattern, topic_name, expected):
    """A message reaches a subscription by MQTT's filter rules (paho's matcher)."""
    got: list[str] = []

    async def handler(topic: str, _payload: bytes) -> None:
        got.append(topic)

    client = BrokerClient("mqtt://127.0.0.1:1", "matching")
    await client.subscribe(pattern, handler)
    client._dispatch(topic_name, b"{}")
    await asyncio.sleep(0.01)
    await client.stop()
    assert (got == [topic_name]) is expected
