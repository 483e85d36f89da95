"""Broker consumers read shared models, never raw dicts (messaging/inbound.py)."""

import orjson
import pytest

from dronefleet.ground.manager.stream import _read
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.inbound import parse_message, speaks_for_itself
from dronefleet.messaging.status import Alarm

ALARM = {
    "drone_id": "QUAD_1",
    "level": "CRITICAL",
    "position": {"lat": 40.6, "lon": -8.6, "alt_m": 12.0},
    "vehicle_time_s": 31.5,
}


def test_a_valid_message_comes_back_as_its_model_ignoring_fields_a_newer_drone_adds():
    alarm = parse_message(Alarm, orjson.dumps({**ALARM, "added_in_v9": 1}))
    assert isinstance(alarm, Alarm)
    assert alarm.level == "CRITICAL" and alarm.position.lat == 40.6


@pytest.mark.parametrize(
    "payload",
    [
        b"not json",
        b"[1, 2]",
        orjson.dumps({**ALARM, "level": "PANIC"}),
        orjson.dumps({**ALARM, "position": {"lat": 91, "lon": 0, "alt_m": 0}}),
        orjson.dumps({k: v for k, v in ALARM.items() if k != "vehicle_time_s"}),
    ],
)
def test_a_malformed_message_is_refused_with_the_reason(payload):
    with pytest.raises(MessageError):
        parse_message(Alarm, payload)


def test_a_drone_speaks_only_for_itself():
    speaks_for_itself("QUAD_1/alarms/out", "QUAD_1")
    with pytest.raises(MessageError, match="QUAD_1"):
        speaks_for_itself("EVIL/alarms/out", "QUAD_1")


def test_the_live_stream_relays_validated_fields_and_refuses_a_forged_sender():
    kind, drone_id, data = _read("QUAD_1/alarms/out", orjson.dumps(ALARM))
    assert (kind, drone_id, data["level"]) == ("alarm", "QUAD_1", "CRITICAL")
    with pytest.raises(MessageError):
        _read("QUAD_2/alarms/out", orjson.dumps(ALARM))
    with pytest.raises(MessageError):
        _read("ground/planner/events", orjson.dumps({"event": "nonsense", "mission_id": "M1"}))
