"""``dronefleet bridge-config`` gives the seed's Listing 4.3 for a drone."""

from __future__ import annotations

import pytest

from dronefleet.cli import main
from dronefleet.messaging.bridge import bridge_config


def test_the_listing_of_the_seed(capsys, tmp_path):
    secret = tmp_path / "drone.secret"
    secret.write_text("dronePassword\n")
    assert (
        main(
            [
                "bridge-config",
                "--drone-id",
                "REVOLUTION_94E041",
                "--ground",
                "10.0.0.5:1883",
                "--username",
                "droneUsername",
                "--password-file",
                str(secret),
            ]
        )
        == 0
    )
    lines = capsys.readouterr().out.splitlines()
    for expected in [
        "address 10.0.0.5:1883",
        "username droneUsername",
        "password dronePassword",
        "clientid droneMosquitto-REVOLUTION_94E041",
        # Requests are never queued on the ground for a bridge that is away (issue 13)...
        'topic REVOLUTION_94E041/control/in in 0 "" ""',
        'topic REVOLUTION_94E041/mission/in in 0 "" ""',
        'topic REVOLUTION_94E041/gear/in in 0 "" ""',
        # ... what the ground must get is kept for it; telemetry and heartbeats are not.
        'topic +/control/out out 1 "" ""',
        'topic +/mission/out out 1 "" ""',
        'topic +/alarms/out out 1 "" ""',
        'topic +/telemetry/out out 0 "" ""',
        'topic +/heartbeats/out out 0 "" ""',
        "cleansession false",
        "local_cleansession false",
        "max_queued_messages 50000",
        "try_private false",  # RabbitMQ's MQTT adapter refuses Mosquitto's private bridge bit
    ]:
        assert expected in lines
    assert sum(line.startswith("topic ") for line in lines) == 9


def test_a_whole_config_with_a_listener_and_bad_input_refused():
    files = ("/etc/drone/passwords", "/etc/drone/acl")
    text = bridge_config("D1", "ground", 1884, listener=("127.0.0.1", 1999), local_users=files)
    assert text.splitlines()[1:5] == [
        "listener 1999 127.0.0.1",
        "allow_anonymous false",
        "password_file /etc/drone/passwords",
        "acl_file /etc/drone/acl",
    ]
    with pytest.raises(ValueError, match="password and ACL"):
        bridge_config("D1", "ground", 1884, listener=("127.0.0.1", 1999))
    with pytest.raises(ValueError):
        bridge_config("a/b", "ground")
    with pytest.raises(ValueError):
        bridge_config("D1", "ground host")


def test_the_drones_anonymous_listener_is_refused_off_loopback():
    """Issue 12: only the drone's own parts may reach its broker without credentials."""
    with pytest.raises(ValueError, match="loopback"):
        bridge_config("D1", "ground", 1884, listener=("0.0.0.0", 1999), local_users=("/p", "/a"))
