"""MAVLink FTP's payload (the 251 bytes of FILE_TRANSFER_PROTOCOL) as PX4 and QGroundControl encode it, its opcodes
and NAK codes (PX4's mavlink_ftp.h), and the vehicle's paths: every path is inside the vehicle's root, whatever it
says.

    seq u16 | session u8 | opcode u8 | size u8 | req_opcode u8 | burst_complete u8 | padding u8 | offset u32 | data[239]

Paths: "/" is the root (PX4's /fs/microsd; "/fs/microsd/..." is taken as the same); "." and empty components are
ignored; a ".." component, a symbolic link anywhere on the way, or text that is not UTF-8 is refused (errno EACCES or
EINVAL in a kErrFailErrno NAK), so nothing outside the root is reachable. A path under /log is in the log folder
(which may be elsewhere, `--log-dir`).
"""

from __future__ import annotations

import errno
import os
import struct
import zlib
from dataclasses import dataclass
from enum import IntEnum
from pathlib import Path

PAYLOAD_BYTES = 251
HEADER = struct.Struct("<HBBBBBBI")
MAX_DATA = PAYLOAD_BYTES - HEADER.size  # 239
ALIAS = ("fs", "microsd")  # PX4's SD card mount point, the same root here
LOG_COMPONENT = "log"


class Opcode(IntEnum):
    NONE = 0
    TERMINATE_SESSION = 1
    RESET_SESSIONS = 2
    LIST_DIRECTORY = 3
    OPEN_FILE_RO = 4
    READ_FILE = 5
    CREATE_FILE = 6
    WRITE_FILE = 7
    REMOVE_FILE = 8
    CREATE_DIRECTORY = 9
    REMOVE_DIRECTORY = 10
    OPEN_FILE_WO = 11
    TRUNCATE_FILE = 12
    RENAME = 13
    CALC_FILE_CRC32 = 14
    BURST_READ_FILE = 15
    ACK = 128
    NAK = 129


class Nak(IntEnum):
    """The error codes of a NAK's data[0] (kErrFailErrno: errno in data[1])."""

    NONE = 0
    FAIL = 1
    FAIL_ERRNO = 2
    INVALID_DATA_SIZE = 3
    INVALID_SESSION = 4
    NO_SESSIONS_AVAILABLE = 5
    EOF = 6
    UNKNOWN_COMMAND = 7
    FILE_EXISTS = 8
    FILE_PROTECTED = 9
    FILE_NOT_FOUND = 10


@dataclass(frozen=True)
class Payload:
    seq: int
    session: int
    opcode: int
    size: int
    req_opcode: int
    burst_complete: int
    offset: int
    data: bytes  # all 239 bytes (the first `size` of them are the request's)

    @classmethod
    def decode(cls, raw: bytes) -> Payload:
        raw = bytes(raw[:PAYLOAD_BYTES]).ljust(PAYLOAD_BYTES, b"\0")
        seq, session, opcode, size, req_opcode, burst, _, offset = HEADER.unpack_from(raw)
        return cls(seq, session, opcode, size, req_opcode, burst, offset, raw[HEADER.size :])

    def encode(self) -> bytes:
        header = HEADER.pack(self.seq & 0xFFFF, self.session, self.opcode, self.size, self.req_opcode,
                             self.burst_complete, 0, self.offset & 0xFFFFFFFF)  # fmt: skip
        return (header + self.data[:MAX_DATA]).ljust(PAYLOAD_BYTES, b"\0")

    @property
    def text(self) -> bytes:
        """The data as a C string: up to the first NUL within `size`."""
        return self.data[: min(self.size, MAX_DATA)].split(b"\0", 1)[0]


def reply(request: Payload, opcode: Opcode, data: bytes = b"", *, offset: int | None = None, session: int | None = None,
          burst_complete: int = 0, seq: int | None = None) -> Payload:  # fmt: skip
    """An ACK or NAK to `request`: the next sequence number, the request's opcode in req_opcode."""
    return Payload(request.seq + 1 if seq is None else seq, request.session if session is None else session, opcode,
                   len(data), request.opcode, burst_complete, request.offset if offset is None else offset,
                   data.ljust(MAX_DATA, b"\0"))  # fmt: skip


def nak_data(code: Nak, error: int = 0) -> bytes:
    """A NAK's data: the code, and errno for kErrFailErrno."""
    return bytes((code, error & 0xFF)) if code == Nak.FAIL_ERRNO else bytes((code,))


def nak_for(exc: OSError) -> bytes:
    """The NAK PX4 sends for a failed system call: ENOENT File Not Found, EEXIST File Exists, else errno."""
    if exc.errno == errno.ENOENT:
        return nak_data(Nak.FILE_NOT_FOUND)
    if exc.errno == errno.EEXIST:
        return nak_data(Nak.FILE_EXISTS)
    return nak_data(Nak.FAIL_ERRNO, exc.errno or errno.EIO)


def crc32_update(checksum: int, block: bytes) -> int:
    """PX4's CRC32 (NuttX's crc32part, what kCmdCalcFileCRC32 answers and MAVSDK checks): the reflected CRC-32
    polynomial from 0, without zlib's inversion before and after."""
    return zlib.crc32(block, checksum ^ 0xFFFFFFFF) ^ 0xFFFFFFFF


class PathRefused(Exception):
    """A path that names nothing inside the root: the NAK data to answer with."""

    def __init__(self, nak: bytes, why: str) -> None:
        super().__init__(why)
        self.nak = nak


@dataclass(frozen=True)
class FileRoot:
    """The root MAVLink FTP serves, its log folder, and the files only the autopilot writes (read-only here)."""

    root: Path
    log_dir: Path
    protected: frozenset[Path] = frozenset()

    def resolve(self, text: bytes) -> Path:
        """The host path a request's path names (PathRefused if it would leave the root)."""
        try:
            decoded = text.decode("utf-8")
        except UnicodeDecodeError:
            raise PathRefused(nak_data(Nak.FAIL_ERRNO, errno.EINVAL), "path is not UTF-8") from None
        parts = [part for part in decoded.split("/") if part not in ("", ".")]
        if ".." in parts:
            raise PathRefused(nak_data(Nak.FAIL_ERRNO, errno.EACCES), "'..' in a path")
        if tuple(parts[:2]) == ALIAS:
            parts = parts[2:]
        base = self.root
        if parts and parts[0] == LOG_COMPONENT:
            base, parts = self.log_dir, parts[1:]
        path = base.joinpath(*parts)
        _refuse_links(base, parts)
        return path

    def writable(self, path: Path) -> None:
        """PathRefused (File Protected) for the files the autopilot keeps: its parameter and mission files, and the
        component metadata."""
        if path in self.protected or any(path.is_relative_to(p) for p in self.protected if p.is_dir()):
            raise PathRefused(nak_data(Nak.FILE_PROTECTED), f"{path.name} is the autopilot's")
        if path in (self.root, self.log_dir):
            raise PathRefused(nak_data(Nak.FILE_PROTECTED), "the root and the log folder stay")


def _refuse_links(base: Path, parts: list[str]) -> None:
    """PathRefused if the base or any existing component on the way is a symbolic link."""
    current = base
    for part in ["", *parts]:
        current = current / part if part else current
        if os.path.islink(current):
            raise PathRefused(nak_data(Nak.FAIL_ERRNO, errno.EACCES), f"{part or base.name} is a link")
