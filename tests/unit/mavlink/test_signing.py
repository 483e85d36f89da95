"""MAVLink 2 message signing in the codec (issue 12): what a key signs is accepted by the same key
only, once; unsigned frames are dropped and counted, except RADIO_STATUS."""

from __future__ import annotations

import hashlib

import pytest

from dronefleet.protocols.mavlink.codec import Encoder, FrameDecoder, signing_key
from dronefleet.protocols.mavlink.codec import dialect as mav

KEY = signing_key("correct horse battery staple")


def arm() -> mav.MAVLink_message:
    return mav.MAVLink_command_long_message(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0,
                                            1, 0, 0, 0, 0, 0, 0)  # fmt: skip


def test_a_passphrase_is_hashed_as_mavproxy_does_and_hex_is_the_key_itself():
    assert hashlib.sha256(b"correct horse battery staple").digest() == KEY
    assert signing_key("ab" * 32) == bytes.fromhex("ab" * 32)
    assert signing_key("  secret\n") == signing_key("secret")  # as read from a file
    with pytest.raises(ValueError, match="empty"):
        signing_key(" \n")


def test_signed_frames_pass_with_the_same_key():
    frame = Encoder(255, 190, signing=KEY).pack(arm())
    assert len(frame) == len(Encoder(255, 190).pack(arm())) + 13  # link id, timestamp, signature
    decoder = FrameDecoder(signing=KEY)
    [got] = decoder.feed_datagram(frame)
    assert got.command == mav.MAV_CMD_COMPONENT_ARM_DISARM and decoder.unsigned == 0


@pytest.mark.parametrize("sender", ["unsigned", "wrong key"])
def test_unsigned_or_wrongly_signed_frames_are_dropped_and_counted(sender):
    encoder = Encoder(255, 190) if sender == "unsigned" else Encoder(255, 190, signing=b"x" * 32)
    decoder = FrameDecoder(signing=KEY)
    assert decoder.feed_datagram(encoder.pack(arm())) == []
    assert decoder.unsigned == 1 and decoder.errors == 0 and decoder.messages == 0


def test_a_replayed_frame_is_dropped():
    frame = Encoder(255, 190, signing=KEY).pack(arm())
    decoder = FrameDecoder(signing=KEY)
    assert len(decoder.feed_datagram(frame)) == 1
    assert decoder.feed_datagram(frame) == []  # same timestamp again: a replay
    assert decoder.unsigned == 1


def test_radio_status_from_a_radio_that_cannot_sign_still_passes():
    radio = mav.MAVLink_radio_status_message(200, 190, 100, 80, 70, 0, 0)
    decoder = FrameDecoder(signing=KEY)
    [got] = decoder.feed_datagram(Encoder(51, 68).pack(radio))
    assert got.get_type() == "RADIO_STATUS"


def test_a_decoder_without_a_key_reads_signed_frames():
    # A ground station without the key still sees the signed vehicle's telemetry (as with
    # ArduPilot): signing authenticates, it does not encrypt.
    beat = mav.MAVLink_heartbeat_message(2, 3, 0, 0, 3, 3)
    [got] = FrameDecoder().feed_datagram(Encoder(1, 1, signing=KEY).pack(beat))
    assert got.get_type() == "HEARTBEAT"
