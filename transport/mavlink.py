"""MAVLink 2 framing via pymavlink's generated `common` dialect, with counting of everything dropped.

pymavlink frames and checks everything, except the plant link's per-step messages, which
transport/mavlink_frames.py packs and parses with precompiled structs into the same bytes. This module keeps a
parser per link that survives any input (random bytes, truncated frames, bad CRC, unknown ids) and counts what it
could not use, so bad input is refused visibly and never raises into a control loop.
"""

from __future__ import annotations

import os
from collections import Counter

os.environ.setdefault("MAVLINK20", "1")

from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from transport.link_signing import sign_everything  # noqa: E402
from transport.mavlink_frames import FastFrames, FrameFormat  # noqa: E402

MAV_RESULT_ACCEPTED = mavlink.MAV_RESULT_ACCEPTED
MAV_RESULT_DENIED = mavlink.MAV_RESULT_DENIED
MAV_RESULT_UNSUPPORTED = mavlink.MAV_RESULT_UNSUPPORTED
MAV_RESULT_FAILED = mavlink.MAV_RESULT_FAILED


def drop_reason(parser_reason: str) -> str:
    """The counter a frame pymavlink could not use goes to."""
    reason = parser_reason.lower()
    if "signature" in reason:
        return "bad_signature"  # unsigned, another key, or replayed, on a link that signs (transport/link_signing.py)
    return "bad_crc" if "crc" in reason else "bad_data"


class Link:
    """One MAVLink endpoint's encoder and robust parser with drop counters."""

    def __init__(
        self,
        system_id: int,
        component_id: int,
        signing_key: bytes | None = None,
        fast: tuple[FrameFormat, ...] = (),
        checked: tuple[FrameFormat, ...] = (),
    ) -> None:
        """`signing_key`: sign everything sent and keep only frames signed with it (transport/link_signing.py).
        `fast`: message types parsed by precompiled structs (transport/mavlink_frames.py), of which `checked` are
        only checked and not returned (on the fast path: pymavlink's parser returns what it decodes)."""
        self.mav = mavlink.MAVLink(None, srcSystem=system_id, srcComponent=component_id)
        self.mav.robust_parsing = True
        self.dropped: Counter[str] = Counter()
        if signing_key is not None:
            sign_everything(self.mav, signing_key)
        self.frames = FastFrames(self.mav, fast, checked)

    def parse(self, data: bytes) -> list[mavlink.MAVLink_message]:
        """Every good message in one UDP datagram; bad frames are counted in `dropped`, never raised."""
        fast = self.frames.parse(data)
        if fast is not None:
            return fast
        try:
            messages = self.mav.parse_buffer(data) or []
        except (mavlink.MAVError, IndexError, ValueError) as exc:  # defensive: any frame pymavlink rejects
            self.dropped["malformed:" + type(exc).__name__] += 1
            messages = []
        if self.mav.buf_len() > 0:
            # A UDP datagram carries whole frames: a partial frame at its end is truncated, and keeping it
            # would corrupt the next datagram's first (good) frame.
            self.dropped["truncated"] += 1
            self.mav.buf = bytearray()
            self.mav.buf_index = 0
            self.mav.expected_length = mavlink.HEADER_LEN_V1 + 2
        good = []
        for message in messages:
            if isinstance(message, mavlink.MAVLink_bad_data):
                self.dropped[drop_reason(message.reason or "")] += 1
            elif isinstance(message, mavlink.MAVLink_unknown):
                self.dropped["unknown_message"] += 1
            else:
                good.append(message)
        return good

    def pack(self, message: mavlink.MAVLink_message) -> bytes:
        """Frame one message (signed when the link has a key) with the link's sequence number, which then
        advances, as pymavlink's `send` does (receivers count lost frames by its gaps)."""
        frame = message.pack(self.mav)
        self._advance_sequence()
        return frame

    def pack_fields(self, frame_format: FrameFormat, *fields: object) -> bytes:
        """Frame one message from its fields (pymavlink's `<name>_encode` arguments): the bytes
        `pack` would give, without building a message object."""
        frame = self.frames.pack(frame_format, *fields)
        self._advance_sequence()
        return frame

    def _advance_sequence(self) -> None:
        self.mav.seq = (self.mav.seq + 1) % 256
