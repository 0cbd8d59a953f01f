"""The plant link's precompiled frames (transport/mavlink_frames.py) are pymavlink's, bit for bit, both ways."""

from __future__ import annotations

import random
import struct

import pytest

from transport.mavlink import Link
from transport.mavlink_frames import (
    HIL_GPS,
    HIL_SENSOR,
    HIL_STATE_QUATERNION,
    PLANT_STEP_FORMATS,
    SERVO_OUTPUT_RAW,
    FrameFormat,
)

KEY = bytes(range(32))


INTEGER_BITS = {"int8_t": 8, "int16_t": 16, "int32_t": 32, "int64_t": 64}


def random_value(rng: random.Random, field_type: str) -> float | int:
    if rng.random() < 0.2:
        return 0  # zeros at the end of a payload are stripped on the wire
    if field_type == "float":
        return struct.unpack("<f", struct.pack("<f", rng.uniform(-1e4, 1e4)))[0]  # exactly representable
    bits = INTEGER_BITS[field_type.removeprefix("u")]
    return (
        rng.randrange(1 << bits) if field_type.startswith("u") else rng.randrange(-(1 << (bits - 1)), 1 << (bits - 1))
    )


def random_fields(rng: random.Random, frame_format: FrameFormat) -> list:
    """Random values of the right types for every field, in pymavlink's argument order."""
    cls = frame_format.message_class
    return [[random_value(rng, field_type) for _ in range(length)] if length else random_value(rng, field_type)
            for field_type, length in zip(cls.fieldtypes, cls.array_lengths)]  # fmt: skip


def pymavlink_frame(link: Link, frame_format: FrameFormat, fields: list) -> bytes:
    return link.pack(frame_format.message_class(*fields))


@pytest.mark.parametrize("frame_format", PLANT_STEP_FORMATS, ids=lambda f: f.name)
def test_packed_frames_are_pymavlinks_and_parse_back_the_same(frame_format: FrameFormat) -> None:
    rng = random.Random(frame_format.msgid)
    ours, theirs = Link(1, 200, fast=PLANT_STEP_FORMATS), Link(1, 200)
    reader_fast, reader_slow = Link(1, 1, fast=PLANT_STEP_FORMATS), Link(1, 1)
    for _ in range(300):
        fields = random_fields(rng, frame_format)
        frame = ours.pack_fields(frame_format, *fields)
        assert frame == pymavlink_frame(theirs, frame_format, fields)
        fast, slow = reader_fast.parse(frame), reader_slow.parse(frame)
        assert [m.to_dict() for m in fast] == [m.to_dict() for m in slow]
        assert [(m.get_srcSystem(), m.get_srcComponent(), m.get_seq(), bytes(m.get_msgbuf())) for m in fast] == \
            [(m.get_srcSystem(), m.get_srcComponent(), m.get_seq(), bytes(m.get_msgbuf())) for m in slow]  # fmt: skip
    assert reader_fast.dropped == reader_slow.dropped == {}
    assert ours.mav.seq == theirs.mav.seq == 300 % 256


def test_a_step_datagram_and_extensions_left_out() -> None:
    """HIL_STATE_QUATERNION + HIL_SENSOR + HIL_GPS in one datagram, packed without their extension fields (0)."""
    ours, theirs = Link(1, 200, fast=PLANT_STEP_FORMATS), Link(1, 200)
    state = (2500, (1.0, 0.0, 0.0, 0.0), 0.1, -0.2, 0.3, 404_443_000, -799_960_000, 400_000, 10, -20, 30, 1500, 1500,
             0, 0, -1000)  # fmt: skip
    sensor = (2500, *[0.5] * 13, 0x1FFF)
    gps = (2500, 3, 404_443_000, -799_960_000, 400_000, 100, 100, 22, 10, -20, 30, 27000, 12)
    datagram = b"".join(ours.pack_fields(f, *v) for f, v in ((HIL_STATE_QUATERNION, state), (HIL_SENSOR, sensor),
                                                               (HIL_GPS, gps)))  # fmt: skip
    expected = b"".join((theirs.pack(theirs.mav.hil_state_quaternion_encode(*state)),
                         theirs.pack(theirs.mav.hil_sensor_encode(*sensor)),
                         theirs.pack(theirs.mav.hil_gps_encode(*gps))))  # fmt: skip
    assert datagram == expected
    parsed = Link(1, 1, fast=PLANT_STEP_FORMATS).parse(datagram)
    assert [m.get_type() for m in parsed] == ["HIL_STATE_QUATERNION", "HIL_SENSOR", "HIL_GPS"]
    assert [m.get_seq() for m in parsed] == [0, 1, 2]  # each frame advances the link's sequence, as pymavlink's send
    assert parsed[0].attitude_quaternion == [1.0, 0.0, 0.0, 0.0] and parsed[1].id == 0 and parsed[2].yaw == 0


def test_checked_types_are_checked_not_returned() -> None:
    """The autopilot's plant link checks HIL_SENSOR and HIL_GPS without decoding them: a good step datagram gives
    HIL_STATE_QUATERNION alone, and a bad frame of a checked type is still refused and counted as pymavlink does."""
    sender = Link(1, 200, fast=PLANT_STEP_FORMATS)
    state = (2500, (1.0, 0.0, 0.0, 0.0), 0.1, -0.2, 0.3, 404_443_000, -799_960_000, 400_000, 10, -20, 30, 1500, 1500,
             0, 0, -1000)  # fmt: skip
    datagram = sender.pack_fields(HIL_STATE_QUATERNION, *state) + sender.pack_fields(HIL_SENSOR, 2500, *[0.5] * 13, 7)
    reader = Link(1, 1, fast=PLANT_STEP_FORMATS, checked=(HIL_SENSOR, HIL_GPS))
    assert [(m.get_type(), m.time_usec) for m in reader.parse(datagram)] == [("HIL_STATE_QUATERNION", 2500)]
    bad = bytearray(datagram)
    bad[-1] ^= 0xFF  # the HIL_SENSOR frame's CRC
    slow = Link(1, 1)
    assert [m.get_type() for m in reader.parse(bytes(bad))] == [m.get_type() for m in slow.parse(bytes(bad))] == [
        "HIL_STATE_QUATERNION"]  # fmt: skip
    assert reader.dropped == slow.dropped and sum(slow.dropped.values()) == 1


def test_anything_irregular_goes_to_pymavlink_and_is_counted_the_same() -> None:
    sender = Link(1, 1)
    good = sender.pack_fields(SERVO_OUTPUT_RAW, 2500, 0, *[1500] * 12)
    heartbeat = sender.pack(sender.mav.heartbeat_encode(2, 12, 0, 0, 4))
    bad_crc = bytearray(good)
    bad_crc[-1] ^= 0xFF
    cases = [good + heartbeat, bytes(bad_crc), good + good[:10], good[:-1], b"\x00" * 40, good + bytes(bad_crc), b""]
    for data in cases:
        fast, slow = Link(1, 200, fast=PLANT_STEP_FORMATS), Link(1, 200)
        assert [m.to_dict() for m in fast.parse(data)] == [m.to_dict() for m in slow.parse(data)]
        assert fast.dropped == slow.dropped


def test_a_signing_link_keeps_pymavlinks_signing() -> None:
    """Signing is not on the fast path: a signing link's frames are pymavlink's signed ones, and it refuses unsigned
    frames of the fast types as before."""
    ours, theirs = Link(1, 1, KEY, fast=PLANT_STEP_FORMATS), Link(1, 1, KEY)
    theirs.mav.signing.timestamp = ours.mav.signing.timestamp  # both signed at the same time
    fields = (2500, 0, *[1500] * 12)
    frame = ours.pack_fields(SERVO_OUTPUT_RAW, *fields)
    assert frame == theirs.pack(theirs.mav.servo_output_raw_encode(*fields, 0, 0, 0, 0))
    reader = Link(1, 200, KEY, fast=PLANT_STEP_FORMATS)
    assert [m.get_type() for m in reader.parse(frame)] == ["SERVO_OUTPUT_RAW"]
    assert reader.parse(Link(1, 1).pack_fields(SERVO_OUTPUT_RAW, *fields)) == []
    assert reader.dropped == {"bad_signature": 1}
