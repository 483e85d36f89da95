"""A RabbitMQ user in a vhost logs in over MQTT as ``vhost:user``; in a broker URL the ':' is
written ``%3A`` (issue 25), or it would end the user name and start the password."""

from __future__ import annotations

import dataclasses

from dronefleet.cli.args import broker_with_password
from dronefleet.messaging.url import BrokerUrl


def test_an_encoded_colon_is_part_of_the_user_name_and_survives_a_round_trip() -> None:
    url = BrokerUrl.parse("mqtt://fleet%3Aground:s3cret@rabbit.example:1884")
    assert (url.username, url.password, url.host, url.port) == (
        "fleet:ground", "s3cret", "rabbit.example", 1884,
    )  # fmt: skip
    assert url.full() == "mqtt://fleet%3Aground:s3cret@rabbit.example:1884"
    assert BrokerUrl.parse(url.full()) == url
    assert str(url) == "mqtt://fleet%3Aground:***@rabbit.example:1884"  # as it must be written


def test_a_password_from_a_file_keeps_the_user_name_encoded(tmp_path) -> None:
    secret = tmp_path / "ground.secret"
    secret.write_text("p@ss:word/1\n")
    full = broker_with_password("mqtt://fleet%3Aground@127.0.0.1:1884", secret)
    url = BrokerUrl.parse(full)
    assert (url.username, url.password) == ("fleet:ground", "p@ss:word/1")
    assert full.startswith("mqtt://fleet%3Aground:")


def test_an_unencoded_colon_is_read_as_user_and_password() -> None:
    """Why the README says %3A: ``fleet:ground@`` is user ``fleet`` with password ``ground``."""
    url = BrokerUrl.parse("mqtt://fleet:ground@rabbit.example:1884")
    assert (url.username, url.password) == ("fleet", "ground")
    vhost_user = dataclasses.replace(url, username="fleet:ground", password=None)
    assert vhost_user.full() == "mqtt://fleet%3Aground@rabbit.example:1884"
