"""Live Link Face's UDP packet (blendvoca.live.livelink_udp): byte layout, round trip, refusals."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from blendvoca.errors import DataError, UserError
from blendvoca.live.livelink_udp import (
    PACKET_NAMES,
    decode_packet,
    encode_packet,
    packet_values,
    rate_fraction,
    unknown_names,
)
from blendvoca.names import ARKIT_FACE_ORDER, LIVELINK_ROTATION_COLUMNS


def test_the_packet_has_the_version_6_layout_byte_by_byte():
    values = np.arange(61, dtype=np.float64) / 64  # exact in float32
    data = encode_packet(values, device_id="dev", subject="Face", frame_number=1234, rate=(60000, 1001),
                         sub_frame=0.5)
    expected = (b"\x06" + struct.pack(">i", 3) + b"dev" + struct.pack(">i", 4) + b"Face"
                + struct.pack(">ifiiB", 1234, 0.5, 60000, 1001, 61) + struct.pack(">61f", *values))
    assert data == expected
    assert len(data) == 1 + 4 + 3 + 4 + 4 + 16 + 1 + 61 * 4


def test_the_61_slots_are_unreals_blendshape_enum_then_the_rotations():
    assert len(PACKET_NAMES) == 61
    assert PACKET_NAMES[14:17] == ("jawForward", "jawLeft", "jawRight")  # EARFaceBlendShape: Left before Right
    assert PACKET_NAMES[21:23] == ("mouthLeft", "mouthRight")
    assert PACKET_NAMES[51] == "tongueOut" and PACKET_NAMES[52:] == tuple(LIVELINK_ROTATION_COLUMNS)


def test_decode_inverts_encode_to_float32_precision():
    rng = np.random.default_rng(0)
    values = rng.uniform(-1, 1, 61)
    packet = decode_packet(encode_packet(values, device_id="iPhone ü", subject="Subj", frame_number=-7,
                                         rate=(30, 1), sub_frame=0.25))
    assert (packet.device_id, packet.subject, packet.frame_number, packet.sub_frame, packet.rate) == (
        "iPhone ü", "Subj", -7, 0.25, (30, 1))
    np.testing.assert_array_equal(packet.values, values.astype(np.float32))


@pytest.mark.parametrize("fps, fraction", [(60, (60, 1)), (60000 / 1001, (60000, 1001)), (29.97, (30000, 1001)),
                                           (25, (25, 1)), (24000 / 1001, (24000, 1001)), (100, (100, 1))])
def test_rates_are_unreals_frame_rate_fractions(fps, fraction):
    assert rate_fraction(fps) == fraction


def _packet() -> bytes:
    return encode_packet(np.zeros(61), device_id="d", subject="s", frame_number=0)


@pytest.mark.parametrize("mutate, message", [
    (lambda b: b"\x05" + b[1:], "version 5; expected 6"),
    (lambda b: b[:-1], "ends inside its values"),
    (lambda b: b + b"\x00", "1 bytes after its 61 values"),
    (lambda b: b[:1] + struct.pack(">i", 1 << 20) + b[5:], "ends inside its device id"),
    (lambda b: b[:27] + b"\x34" + b[28:], "carries 52 values; expected 61"),
    (lambda b: b"", "ends inside its version"),
])
def test_malformed_packets_are_refused_with_the_reason(mutate, message):
    with pytest.raises(DataError, match=message):
        decode_packet(mutate(_packet()))


def test_track_columns_go_to_their_slots_by_name_in_any_case():
    names = ["JawOpen", "mouthleft", "headYaw"]
    weights = np.array([[0.5, 0.25, 0.125], [1.0, 0.0, -0.5]])
    values = packet_values(weights, names)
    assert values.shape == (2, 61) and values.dtype == np.float32
    np.testing.assert_array_equal(values[:, PACKET_NAMES.index("jawOpen")], [0.5, 1.0])
    np.testing.assert_array_equal(values[:, PACKET_NAMES.index("mouthLeft")], [0.25, 0.0])
    np.testing.assert_array_equal(values[:, PACKET_NAMES.index("HeadYaw")], [0.125, -0.5])
    assert np.count_nonzero(values) == 5


def test_a_takes_rotations_fill_the_last_nine_slots():
    pose = np.arange(18, dtype=float).reshape(2, 9) / 8
    values = packet_values(np.ones((2, 52)), ARKIT_FACE_ORDER, pose)
    np.testing.assert_array_equal(values[:, 52:], pose)
    np.testing.assert_array_equal(values[:, :52], 1)


def test_names_the_packet_has_no_slot_for_are_named():
    assert unknown_names(["jawOpen", "JAW_OPEN", "HeadYaw", "browLateral"]) == ["JAW_OPEN", "browLateral"]
    with pytest.raises(UserError, match=r"no slot for \['JAW_OPEN'\]"):
        packet_values(np.zeros((1, 2)), ["jawOpen", "JAW_OPEN"])
    with pytest.raises(UserError, match="names given twice"):
        packet_values(np.zeros((1, 2)), ["jawOpen", "JawOpen"])
