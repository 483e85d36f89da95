"""Message models: the one schema both sides import; bad input becomes a readable reason."""

import base64

import orjson
import pytest

from dronefleet.messaging.codec import MessageError, decode_object, encode
from dronefleet.messaging.commands import Command, parse_control, parse_step
from dronefleet.messaging.missions import MissionRequest, decode_steps, encode_steps_base64


def test_table_4_2_commands_parse():
    nav = parse_control({"command": "navigate", "lat": 40.6, "lon": -8.6, "altitude_delta": 10})
    assert nav.command is Command.NAVIGATE and nav.altitude_delta == 10
    assert parse_control({"command": "changeN", "value": -10}).value == -10
    assert parse_control({"command": "disarm"}).force is False


@pytest.mark.parametrize(
    ("data", "reason"),
    [
        (
            {"command": "navigate", "lat": 90.5, "lon": 0},
            "lat: Input should be less than or equal to 90",
        ),
        ({"command": "changeE", "value": None}, "value"),
        ({"command": "wait_for_flight"}, "unknown control command"),
        ({"value": 1}, "no 'command'"),
    ],
)
def test_invalid_commands_give_reasons(data, reason):
    with pytest.raises(MessageError, match=reason):
        parse_control(data)


def test_mission_only_commands_are_valid_steps():
    assert parse_step({"command": "sleep", "value": 2}).value == 2
    alarm = parse_step({"command": "virtualalarm", "level": "OUT_MEASURE", "message": "hi"})
    assert alarm.level == "OUT_MEASURE"
    with pytest.raises(MessageError, match="level"):
        parse_step({"command": "virtualalarm", "level": "PANIC"})


def test_mission_base64_as_the_seed_sends_it():
    steps = [{"command": "arm"}, {"command": "takeoff"}, {"command": "sleep", "value": 1}]
    encoded = encode_steps_base64(steps)
    assert orjson.loads(base64.b64decode(encoded)) == steps
    decoded = decode_steps(MissionRequest(mission=encoded))
    assert [s.command for s in decoded] == ["arm", "takeoff", "sleep"]
    assert [s.command for s in decode_steps(MissionRequest(steps=steps))] == [
        "arm",
        "takeoff",
        "sleep",
    ]


@pytest.mark.parametrize(
    ("request_", "reason"),
    [
        (MissionRequest(mission="!!!"), "base64"),
        (MissionRequest(mission=base64.b64encode(b"[]").decode()), "non-empty"),
        (MissionRequest(steps=[{"command": "arm"}, {"command": "warp"}]), "step 1"),
        (MissionRequest(), "needs 'mission'"),
    ],
)
def test_bad_missions_are_rejected_with_reasons(request_, reason):
    with pytest.raises(MessageError, match=reason):
        decode_steps(request_)


def test_codec_round_trip_and_errors():
    assert decode_object(encode({"a": 1})) == {"a": 1}
    with pytest.raises(MessageError, match="JSON object"):
        decode_object(b"[1]")
    with pytest.raises(MessageError, match="not valid JSON"):
        decode_object(b"\xff")
