"""MAVLink frames round-trip, and corrupted, truncated or random bytes are rejected without
crashing (the Flight Controller Interface never dies on input)."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from dronefleet.protocols.mavlink import items as mi
from dronefleet.protocols.mavlink.codec import Encoder, FrameDecoder, to_dict
from dronefleet.protocols.mavlink.codec import dialect as mav


def samples() -> list:
    return [
        mav.MAVLink_heartbeat_message(
            mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, 0x81, 4, 4, 3
        ),
        mav.MAVLink_command_long_message(1, 1, 400, 0, 1, 21196, 0, 0, 0, 0, 0),
        mav.MAVLink_global_position_int_message(
            1234, 406300000, -86590000, 10000, 0, 5, -3, 1, 9000
        ),
        mav.MAVLink_statustext_message(2, b"Arm: battery too low", 0, 0),
        mi.waypoint(40.63, -8.659, 10, hold_s=2).to_message(1, 1, 3),
        mav.MAVLink_named_value_float_message(5, b"CO2", 431.25),
    ]


def test_messages_round_trip_field_for_field():
    enc, dec = Encoder(7, 1), FrameDecoder()
    for msg in samples():
        (got,) = dec.feed(enc.pack(msg))
        assert got.get_type() == msg.get_type()
        assert got.get_srcSystem() == 7
        for name, value in to_dict(msg).items():
            if isinstance(value, float):
                assert math.isclose(to_dict(got)[name], value, rel_tol=1e-6)
            elif isinstance(value, bytes):
                assert to_dict(got)[name] == value.decode()
            else:
                assert to_dict(got)[name] == value
    assert dec.errors == 0


def test_a_stream_of_frames_splits_anywhere():
    enc, dec = Encoder(1, 1), FrameDecoder()
    stream = b"".join(enc.pack(m) for m in samples())
    out = []
    for i in range(0, len(stream), 7):  # arbitrary chunking, as a serial port delivers
        out += dec.feed(stream[i : i + 7])
    assert [m.get_type() for m in out] == [m.get_type() for m in samples()]


def test_mission_items_survive_the_wire():
    item = mi.loiter_time(40.63, -8.659, 12.5, 3)
    (got,) = FrameDecoder().feed(Encoder(1, 1).pack(item.to_message(1, 1, 4)))
    assert mi.MissionItem.from_message(got) == item


def test_a_flipped_byte_is_rejected_and_the_next_frame_still_parses():
    enc, dec = Encoder(1, 1), FrameDecoder()
    good = enc.pack(samples()[2])
    bad = bytearray(enc.pack(samples()[2]))
    bad[12] ^= 0x40  # inside the payload: the CRC no longer matches
    assert dec.feed_datagram(bytes(bad)) == []
    assert dec.errors == 1
    assert [m.get_type() for m in dec.feed_datagram(good)] == ["GLOBAL_POSITION_INT"]


def test_a_truncated_frame_yields_nothing():
    frame = Encoder(1, 1).pack(samples()[1])
    dec = FrameDecoder()
    for cut in range(len(frame)):
        assert dec.feed_datagram(frame[:cut]) == []


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=600))
def test_random_bytes_never_crash_the_parser(data):
    dec = FrameDecoder()
    for msg in dec.feed(data):
        msg.get_type()  # whatever survives the CRC is a well-formed message object


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 5), st.data())
def test_any_single_corrupted_byte_is_never_accepted(which, data):
    frame = bytearray(Encoder(1, 1).pack(samples()[which]))
    index = data.draw(st.integers(0, len(frame) - 1))
    flip = data.draw(st.integers(1, 255))
    frame[index] ^= flip
    dec = FrameDecoder()
    got = dec.feed_datagram(bytes(frame))
    assert got == []  # the CRC covers every header byte; unknown ids are dropped too


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=80), st.integers(0, 5))
def test_garbage_before_a_frame_does_not_hide_it_in_a_stream(junk, which):
    junk = junk.replace(b"\xfd", b"\x00").replace(b"\xfe", b"\x00")  # no false frame starts
    dec = FrameDecoder()
    got = dec.feed(junk + Encoder(1, 1).pack(samples()[which]))
    assert [m.get_type() for m in got] == [samples()[which].get_type()]
