"""Broker URLs over TLS: ``mqtts://user@host[:8883]?cafile=PATH`` (issue 12)."""

from __future__ import annotations

import pytest

from dronefleet.messaging.url import BrokerUrl


def test_mqtts_defaults_to_8883_and_keeps_its_ca_through_a_round_trip() -> None:
    url = BrokerUrl.parse("mqtts://QUAD_1:s3cret@ground.example?cafile=/etc/df/ca.pem")
    assert (url.tls, url.port, url.ca_file) == (True, 8883, "/etc/df/ca.pem")
    assert BrokerUrl.parse(url.full()) == url
    assert str(url) == "mqtts://QUAD_1:***@ground.example:8883?cafile=/etc/df/ca.pem"
    assert BrokerUrl.parse("mqtt://h").tls is False and BrokerUrl.parse("mqtt://h").port == 1883


@pytest.mark.parametrize(
    "bad", ["mqtt://h?cafile=/ca.pem", "mqtts://h?insecure=1", "http://h", "mqtts://:8883"]
)
def test_options_only_with_tls_and_only_cafile(bad: str) -> None:
    with pytest.raises(ValueError):
        BrokerUrl.parse(bad)
