"""The ground's NATS link without a server (messaging/nats_link.py): what it refuses, and what
it counts."""

from __future__ import annotations

import nats.errors
import pytest

from dronefleet.messaging.nats_link import NatsLink, NatsNotUsable, nats_servers
from dronefleet.messaging.url import BrokerUrl

GROUND = BrokerUrl("127.0.0.1", 1883, username="ground", password="secret")


def test_the_refusals_name_the_option_that_does_not_apply():
    with pytest.raises(NatsNotUsable, match="--fleet-over-nats wants the NATS client address"):
        nats_servers("mqtt://a:1883", "--fleet-over-nats")
    with pytest.raises(NatsNotUsable, match="--fleet-over-nats needs a NATS broker"):
        NatsLink("nats://a:4222", BrokerUrl.parse("local://g:p@bus"), name="x",
                 option="--fleet-over-nats")  # fmt: skip
    with pytest.raises(NatsNotUsable, match="never anonymously"):
        NatsLink("nats://a:4222", BrokerUrl("a"), name="x", option="--fleet-over-nats")


async def test_only_the_qos_0_stream_is_taken():
    """A NATS subscriber gets a QoS 1 topic's plain messages without their acknowledgements: a
    link that took them would lose what MQTT's session keeps."""
    link = NatsLink("nats://127.0.0.1:1", GROUND, name="x", option="--fleet-over-nats")

    async def handler(_topic: str, _payload: bytes) -> None:
        return None

    with pytest.raises(ValueError, match="QoS 0"):
        await link.subscribe("+/alarms/out", handler, qos=1)


async def test_messages_dropped_behind_are_counted_and_a_refusal_stays_the_reason():
    link = NatsLink("nats://127.0.0.1:1", GROUND, name="x", option="--fleet-over-nats")
    await link._error(
        nats.errors.SlowConsumerError(subject="Q.telemetry.out", reply="", sid=1, sub=None)
    )
    await link._error(
        nats.errors.SlowConsumerError(subject="Q.telemetry.out", reply="", sid=1, sub=None)
    )
    assert link.dropped == 2 and link._last_error is None
    await link._error(Exception("nats: 'Authorization Violation'"))
    await link._error(ConnectionResetError(104, "Connection reset by peer"))
    assert "Authorization" in str(link._last_error)


@pytest.mark.parametrize("option", ["--fleet-over-nats", "--share-ingestion"])
def test_a_wrong_address_on_the_command_line_is_refused_naming_its_own_option(option, capsys):
    from dronefleet.cli import build_parser

    with pytest.raises(SystemExit):
        build_parser().parse_args(["ground", option, "mqtt://a:1883"])
    err = capsys.readouterr().err
    assert f"{option} wants the NATS client address" in err, err
    assert build_parser().parse_args(["ground", option, "nats://a:4222"]) is not None
