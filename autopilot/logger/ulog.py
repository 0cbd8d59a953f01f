"""ULog, PX4's log format (PX4's docs: "ULog File Format"), written from scratch: each function encodes one
message of the format as bytes. Little endian; every message is a 3-byte header (uint16 size of the body, uint8
type) and a body.

    header        "ULog" 0x01 0x12 0x35, version 1, uint64 start time (us)
    'B' flag bits compatibility flags (DEFAULT_PARAMETERS: the log has 'Q' messages), no appended data
    'F' format    "name:type field;type field;..." of a logged message
    'I' info      "type key" and its value (sys_name, ver_sw_release, ...)
    'P' parameter "int32_t NAME" or "float NAME" and its value (in the data section: a change)
    'Q' default   a parameter's default value
    'A' add       subscribe a format under a msg_id (and multi_id)
    'D' data      a sample of a subscribed format: msg_id, then the packed fields
    'L' logged    a text (log level '0'..'7' as MAVLink's MAV_SEVERITY, uint64 time us)
    'S' sync      a magic a reader can resynchronise on
    'O' dropout   samples lost, for this many ms
"""

from __future__ import annotations

import struct

MAGIC = b"ULog\x01\x12\x35"
FILE_VERSION = 1
SYNC_MAGIC = bytes((0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12))
COMPAT_DEFAULT_PARAMETERS = 1  # compat_flags[0] bit 0: the log has default parameters ('Q')
DEFAULT_TYPE_SYSTEM = 1  # 'Q' default_types bit 0: the system-wide default
MAX_BODY = 0xFFFF
MAX_DROPOUT_MS = 0xFFFF

# The ULog basic types and their struct codes (little endian, no padding).
TYPE_CODES = {
    "int8_t": "b", "uint8_t": "B", "int16_t": "h", "uint16_t": "H", "int32_t": "i", "uint32_t": "I",
    "int64_t": "q", "uint64_t": "Q", "float": "f", "double": "d", "bool": "?", "char": "c",
}  # fmt: skip

_HEADER = struct.Struct("<HB")
_UINT64 = struct.Struct("<Q")


class ULogError(ValueError):
    """Something that cannot be encoded as ULog (a body too long, a bad name)."""


def message(kind: str, body: bytes) -> bytes:
    """One message: the size of `body`, its type character, the body."""
    if len(body) > MAX_BODY:
        raise ULogError(f"a ULog '{kind}' message of {len(body)} bytes (at most {MAX_BODY})")
    return _HEADER.pack(len(body), ord(kind)) + body


def file_header(start_usec: int) -> bytes:
    return MAGIC + bytes((FILE_VERSION,)) + _UINT64.pack(start_usec)


def flag_bits(compat: int = COMPAT_DEFAULT_PARAMETERS) -> bytes:
    """'B', the first message after the header: compat flags, no incompatible flags, no appended data."""
    return message("B", bytes((compat, 0, 0, 0, 0, 0, 0, 0)) + bytes(8) + bytes(24))


def format_definition(name: str, fields: str) -> bytes:
    """'F': `fields` as "type name;type name;" (ULog's own field syntax)."""
    return message("F", f"{name}:{fields}".encode("ascii"))


def _keyed(key: str, value: bytes) -> bytes:
    encoded = key.encode("ascii")
    if len(encoded) > 255:
        raise ULogError(f"ULog key too long: {key[:40]}...")
    return bytes((len(encoded),)) + encoded + value


def info_string(key: str, text: str) -> bytes:
    value = text.encode("utf-8")
    return message("I", _keyed(f"char[{len(value)}] {key}", value))


def info_uint32(key: str, value: int) -> bytes:
    return message("I", _keyed(f"uint32_t {key}", struct.pack("<I", value)))


def info_int32(key: str, value: int) -> bytes:
    return message("I", _keyed(f"int32_t {key}", struct.pack("<i", value)))


def _parameter_value(name: str, value: float, integer: bool) -> bytes:
    if integer:
        return _keyed(f"int32_t {name}", struct.pack("<i", int(value)))
    return _keyed(f"float {name}", struct.pack("<f", value))


def parameter(name: str, value: float, integer: bool) -> bytes:
    """'P': a parameter's value (int32_t or float, the two types ULog allows for parameters)."""
    return message("P", _parameter_value(name, value, integer))


def parameter_default(name: str, value: float, integer: bool) -> bytes:
    """'Q': a parameter's system-wide default."""
    return message("Q", bytes((DEFAULT_TYPE_SYSTEM,)) + _parameter_value(name, value, integer))


def subscription(msg_id: int, name: str, multi_id: int = 0) -> bytes:
    """'A': samples of format `name` will come as 'D' messages with `msg_id`."""
    return message("A", struct.pack("<BH", multi_id, msg_id) + name.encode("ascii"))


def data(msg_id: int, payload: bytes) -> bytes:
    """'D': one sample (the packed fields, starting with the uint64 timestamp)."""
    return data_prefix(msg_id, len(payload)) + payload


def data_prefix(msg_id: int, payload_size: int) -> bytes:
    """What comes before a sample of `payload_size` bytes in its 'D' message (the logger keeps one a topic)."""
    return _HEADER.pack(payload_size + 2, ord("D")) + struct.pack("<H", msg_id)


def logged_string(severity: int, time_usec: int, text: str) -> bytes:
    """'L': a text at log level '0'..'7' (the Linux kernel's levels, MAVLink's MAV_SEVERITY numbers)."""
    level = min(max(severity, 0), 7)
    encoded = text.encode("utf-8", "replace")[: MAX_BODY - 9]
    return message("L", struct.pack("<BQ", ord("0") + level, time_usec) + encoded)


def sync() -> bytes:
    return message("S", SYNC_MAGIC)


def dropout(duration_ms: int) -> bytes:
    """'O': samples were lost for `duration_ms` (capped at the field's 65535 ms)."""
    return message("O", struct.pack("<H", min(max(duration_ms, 0), MAX_DROPOUT_MS)))
