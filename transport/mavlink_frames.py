"""Precompiled MAVLink 2 framing for the plant link's per-step messages: the same frames as pymavlink's, faster.

pymavlink builds and parses a frame in ~5-15 us of Python (a message object, a header object, a byte-by-byte
parser state machine); the plant link sends three of them per 2.5 ms step each way. For the few message types
that cross it every step (HIL_STATE_QUATERNION, HIL_SENSOR, HIL_GPS, SERVO_OUTPUT_RAW), `FrameFormat` packs and
unpacks the payload with one precompiled `struct.Struct` taken from pymavlink's own message class (its wire
order, array lengths, CRC extra and id), and `FastFrames` frames it the way pymavlink does: MAVLink 2 header,
trailing zero bytes of the payload stripped, CRC-16/MCRF4XX with the CRC extra, the endpoint's sequence number. The
bytes on the wire are pymavlink's, bit for bit (tests/test_mavlink_frames.py), so any MAVLink peer reads them.

A reader may name types it only wants checked (`checked`: the autopilot reads HIL_SENSOR only now and then): their
frames are checked as the others and left out of the result, the last payload of each kept undecoded (`kept`). Parsing takes the fast path only for a datagram
made entirely of well-formed, unsigned MAVLink 2 frames of those types with good CRCs; anything else (another
message, a bad CRC, a truncated frame, MAVLink 1, a signed frame, a link that signs) goes to pymavlink's parser
whole, so refusals and their counters are exactly pymavlink's.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import Any

from pymavlink.dialects.v20 import common as mavlink

HEADER = struct.Struct("<BBBBBBBHB")  # magic, len, incompat, compat, seq, sysid, compid, msgid (low 16, high 8)
HEADER_LEN = HEADER.size
CRC = struct.Struct("<H")
MAGIC_V2 = 253


_MCRF4XX = mavlink.mcrf4xx  # fastcrc's CRC-16/MCRF4XX, which pymavlink uses too when it is installed (else None)


def frame_crc(after_magic: bytes | memoryview, crc_extra: bytes) -> int:
    """MAVLink's CRC-16/MCRF4XX over the frame after the magic byte, then the message's CRC extra (pymavlink's)."""
    if _MCRF4XX is not None:
        return _MCRF4XX(crc_extra, _MCRF4XX(after_magic))
    crc = mavlink.x25crc(bytes(after_magic))
    crc.accumulate(crc_extra)
    return crc.crc


class FrameFormat:
    """One message type's payload layout, from pymavlink's generated class."""

    def __init__(self, message_class: type[mavlink.MAVLink_message]) -> None:
        if any(field_type.startswith("char") for field_type in message_class.fieldtypes):
            raise ValueError(f"{message_class.msgname}: text fields are not handled by the fast path")
        self.message_class = message_class
        self.name: str = message_class.msgname
        self.msgid: int = message_class.id
        self.crc_extra = bytes((message_class.crc_extra,))
        self.payload_struct = struct.Struct(message_class.unpacker.format)
        self.field_count = len(message_class.fieldnames)
        # The wire order (largest types first) as indices into the argument order, each with its array length
        # (0: a scalar); and for unpacking, each argument's (start, length) in the flat wire tuple.
        wire = []
        for name in message_class.ordered_fieldnames:
            index = message_class.fieldnames.index(name)
            wire.append((index, message_class.array_lengths[index]))
        self.wire = tuple(wire)
        start, slices = 0, [(0, 0)] * self.field_count
        for index, length in self.wire:
            slices[index] = (start, length)
            start += max(length, 1)
        self.arguments = tuple(slices)

    def payload(self, fields: Sequence[Any]) -> bytes:
        """The full payload of the fields in pymavlink's `<name>_encode` argument order (arrays as sequences);
        missing trailing fields (MAVLink 2 extensions) are 0."""
        if len(fields) < self.field_count:
            fields = [*fields, *([0] * (self.field_count - len(fields)))]
        flat: list[Any] = []
        for index, length in self.wire:
            if length:
                flat.extend(fields[index])
            else:
                flat.append(fields[index])
        return self.payload_struct.pack(*flat)

    def fields(self, payload: bytes) -> list[Any]:
        """The fields of a payload (zero-padded to full size) in argument order, arrays as lists."""
        flat = self.payload_struct.unpack(payload)
        return [flat[start] if not length else list(flat[start : start + length]) for start, length in self.arguments]


class FastFrames:
    """Packs and parses the given message types for one pymavlink endpoint (its ids, sequence and signing)."""

    def __init__(
        self, mav: mavlink.MAVLink, formats: Sequence[FrameFormat], checked: Sequence[FrameFormat] = ()
    ) -> None:
        """`formats`: the types `parse` handles (any FrameFormat can be packed); of those, `checked` are only
        checked (header, length, CRC) and left out of the result: a reader that has no use for them."""
        self.mav = mav
        self.formats = {frame_format.msgid: frame_format for frame_format in formats}
        self.checked = frozenset(frame_format.msgid for frame_format in checked)
        self.kept: dict[int, bytes] = {}  # a checked type's last payload (as sent, trailing zeros stripped)

    def pack(self, frame_format: FrameFormat, *fields: Any) -> bytes:
        """One frame with the endpoint's sequence number as `message.pack(mav)` gives it (which does not advance
        it: only pymavlink's `send` does); a signing endpoint packs through pymavlink (signing is not on the fast
        path)."""
        mav = self.mav
        if mav.signing.sign_outgoing:
            return frame_format.message_class(*fields).pack(mav)
        payload = frame_format.payload(fields)
        payload = payload.rstrip(b"\0") or payload[:1]  # MAVLink 2 drops trailing zeros (at least one byte stays)
        msgid = frame_format.msgid
        frame = HEADER.pack(MAGIC_V2, len(payload), 0, 0, mav.seq, mav.srcSystem, mav.srcComponent,
                            msgid & 0xFFFF, msgid >> 16) + payload  # fmt: skip
        return frame + CRC.pack(frame_crc(memoryview(frame)[1:], frame_format.crc_extra))

    def parse(self, data: bytes) -> list[mavlink.MAVLink_message] | None:
        """The messages of a datagram made only of good unsigned MAVLink 2 frames of the known types; None for
        anything else (the caller hands it to pymavlink's parser)."""
        if not self.formats or self.mav.signing.secret_key is not None:
            return None  # a signing link keeps only signed frames: pymavlink checks them
        messages = []
        formats = self.formats
        offset, end = 0, len(data)
        while offset < end:
            if end - offset < HEADER_LEN + 2:
                return None
            magic, length, incompat, compat, seq, system, component, low, high = HEADER.unpack_from(data, offset)
            msgid = low | high << 16
            frame_format = formats.get(msgid)
            crc_at = offset + HEADER_LEN + length
            if magic != MAGIC_V2 or incompat != 0 or frame_format is None or crc_at + 2 > end:
                return None
            size = frame_format.payload_struct.size
            if length > size:
                return None
            crc = CRC.unpack_from(data, crc_at)[0]
            if crc != frame_crc(memoryview(data)[offset + 1 : crc_at], frame_format.crc_extra):
                return None
            if msgid in self.checked:
                self.kept[msgid] = data[offset + HEADER_LEN : crc_at]
                offset = crc_at + 2
                continue
            frame = bytearray(data[offset : crc_at + 2])
            payload = data[offset + HEADER_LEN : crc_at]
            if length < size:
                payload += bytes(size - length)
            message = frame_format.message_class(*frame_format.fields(payload))
            message._msgbuf = frame
            message._payload = frame[6:-2]  # what pymavlink's decode keeps
            message._crc = crc
            message._header = mavlink.MAVLink_header(msgid, incompat, compat, length, seq, system, component)
            messages.append(message)
            offset = crc_at + 2
        return messages


HIL_STATE_QUATERNION = FrameFormat(mavlink.MAVLink_hil_state_quaternion_message)
HIL_SENSOR = FrameFormat(mavlink.MAVLink_hil_sensor_message)
HIL_GPS = FrameFormat(mavlink.MAVLink_hil_gps_message)
SERVO_OUTPUT_RAW = FrameFormat(mavlink.MAVLink_servo_output_raw_message)
RAW_RPM = FrameFormat(mavlink.MAVLink_raw_rpm_message)
# What crosses the plant link every step (docs/plant-link.md): the types both ends parse on the fast path.
PLANT_STEP_FORMATS = (HIL_STATE_QUATERNION, HIL_SENSOR, HIL_GPS, SERVO_OUTPUT_RAW, RAW_RPM)
