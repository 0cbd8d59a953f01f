"""MAVLink FTP (FILE_TRANSFER_PROTOCOL), as PX4's mavlink_ftp serves it: list, open (read-only, write-only, create),
read and burst read, write, truncate, rename, remove, make and remove folders, CRC32, terminate and reset sessions;
on the vehicle's root (autopilot/mavlink/ftp_protocol.py says which paths). Every request gets one ACK or NAK from
our system, component 1, with the request's sequence number plus one; a request sent again (its answer was lost) is
answered with the same reply.

One session at a time, as PX4 (another open: NAK No Sessions Available); a session idle for SESSION_IDLE_S of the
wall clock (the client's time) is closed. A burst read streams its file from the offset asked for, BURST_PER_STEP
packets a plant step, each burst BURST_BYTES long (the last packet says burst_complete), and a NAK EOF at the end.
"""

from __future__ import annotations

import errno
import os
import stat
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from autopilot.mavlink.commands import for_us
from autopilot.mavlink.ftp_protocol import (
    MAX_DATA,
    FileRoot,
    Nak,
    Opcode,
    PathRefused,
    Payload,
    crc32_update,
    nak_data,
    nak_for,
    reply,
)
from autopilot.mavlink.router import GroundLink

SESSION_IDLE_S = 10.0  # PX4's
BURST_BYTES = 35_000  # PX4's burst length
BURST_PER_STEP = 8  # packets of a burst sent per plant step (about 2 kB)
MAX_FILE_BYTES = 256 * 1024 * 1024  # a write or truncate beyond this is refused (EFBIG)
CRC_BLOCK = 64 * 1024
LAST_REPLY_MAX_SIZE = 4  # PX4 keeps small replies (no data read) to send again


@dataclass
class Session:
    handle: BinaryIO
    path: Path
    size: int  # at opening (PX4 reads up to it)
    writable: bool
    link: GroundLink
    client: tuple[int, int]  # the client's system and component
    used_s: float


@dataclass
class Burst:
    offset: int
    seq: int
    sent: int = 0  # bytes of this burst so far


class FtpService:
    def __init__(self, root: FileRoot, *, system_id: int, wall_clock: Callable[[], float] = time.monotonic) -> None:
        self.root = root
        self.system_id = system_id
        self.wall_clock = wall_clock
        self.session: Session | None = None
        self.burst: Burst | None = None
        self._last_reply: tuple[GroundLink, tuple[int, int], Payload] | None = None
        self.requests = 0
        self.naks = 0

    # ---- receiving ----------------------------------------------------------------------------------------------
    def on_file_transfer_protocol(self, link: GroundLink, message) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            return
        self.requests += 1
        request = Payload.decode(bytes(message.payload))
        client = (message.get_srcSystem(), message.get_srcComponent())
        last = self._last_reply
        if last is not None and last[1] == client and (request.seq + 1) & 0xFFFF == last[2].seq:
            self._send(link, client, last[2])
            return
        answer = self._answer(request, link, client)
        if answer is None:  # a burst started: its packets are the answer
            return
        self._send(link, client, answer)
        self._last_reply = (link, client, answer) if answer.size <= LAST_REPLY_MAX_SIZE else None

    def send(self) -> None:
        """Once per plant step: the next packets of a burst read; close a session left idle."""
        session = self.session
        if session is None:
            return
        if self.burst is not None:
            self._burst_packets(session, self.burst)
        elif self.wall_clock() - session.used_s > SESSION_IDLE_S:
            self._close_session()

    def close(self) -> None:
        self._close_session()

    # ---- the requests -------------------------------------------------------------------------------------------
    def _answer(self, request: Payload, link: GroundLink, client: tuple[int, int]) -> Payload | None:
        if request.size > MAX_DATA:
            return self._nak(request, nak_data(Nak.INVALID_DATA_SIZE))
        handlers: dict[int, Callable[[Payload], Payload]] = {
            Opcode.NONE: lambda r: reply(r, Opcode.ACK),
            Opcode.TERMINATE_SESSION: self._terminate,
            Opcode.RESET_SESSIONS: self._reset,
            Opcode.LIST_DIRECTORY: self._list,
            Opcode.READ_FILE: self._read,
            Opcode.WRITE_FILE: self._write,
            Opcode.REMOVE_FILE: self._remove_file,
            Opcode.CREATE_DIRECTORY: self._create_directory,
            Opcode.REMOVE_DIRECTORY: self._remove_directory,
            Opcode.TRUNCATE_FILE: self._truncate,
            Opcode.RENAME: self._rename,
            Opcode.CALC_FILE_CRC32: self._crc32,
        }
        try:
            if request.opcode in (Opcode.OPEN_FILE_RO, Opcode.OPEN_FILE_WO, Opcode.CREATE_FILE):
                return self._open(request, link, client)
            if request.opcode == Opcode.BURST_READ_FILE:
                return self._start_burst(request)
            handler = handlers.get(request.opcode)
            if handler is None:
                return self._nak(request, nak_data(Nak.UNKNOWN_COMMAND))
            return handler(request)
        except PathRefused as refusal:
            return self._nak(request, refusal.nak)
        except OSError as exc:
            return self._nak(request, nak_for(exc))

    def _nak(self, request: Payload, data: bytes) -> Payload:
        self.naks += 1
        return reply(request, Opcode.NAK, data)

    def _open(self, request: Payload, link: GroundLink, client: tuple[int, int]) -> Payload:
        if self.session is not None:
            return self._nak(request, nak_data(Nak.NO_SESSIONS_AVAILABLE))
        path = self.root.resolve(request.text)
        writable = request.opcode != Opcode.OPEN_FILE_RO
        if writable:
            self.root.writable(path)
            flags = os.O_WRONLY | os.O_CREAT | (os.O_TRUNC if request.opcode == Opcode.CREATE_FILE else 0)
        else:
            flags = os.O_RDONLY | os.O_NONBLOCK  # a FIFO left in the root must not hold the loop up
        fd = os.open(path, flags | os.O_NOFOLLOW, 0o644)
        try:
            status = os.fstat(fd)
            if not stat.S_ISREG(status.st_mode):
                raise OSError(errno.EISDIR, "not a file")
            size = status.st_size
            handle = os.fdopen(fd, "wb" if writable else "rb")
        except OSError:
            os.close(fd)
            raise
        self.session = Session(handle, path, size, writable, link, client, self.wall_clock())
        self.burst = None
        return reply(request, Opcode.ACK, size.to_bytes(4, "little") if size < 1 << 32 else b"\xff\xff\xff\xff",
                     session=0)  # fmt: skip

    def _session(self, request: Payload) -> Session | None:
        session = self.session
        if session is None or request.session != 0:
            return None
        session.used_s = self.wall_clock()
        return session

    def _read(self, request: Payload) -> Payload:
        session = self._session(request)
        if session is None or session.writable:
            return self._nak(request, nak_data(Nak.INVALID_SESSION))
        if request.offset >= session.size:
            return self._nak(request, nak_data(Nak.EOF))
        session.handle.seek(request.offset)
        wanted = request.size if 0 < request.size <= MAX_DATA else MAX_DATA
        data = session.handle.read(min(wanted, session.size - request.offset))
        return reply(request, Opcode.ACK, data)

    def _start_burst(self, request: Payload) -> Payload | None:
        session = self._session(request)
        if session is None or session.writable:
            return self._nak(request, nak_data(Nak.INVALID_SESSION))
        self.burst = Burst(request.offset, request.seq + 1)
        return None

    def _burst_packets(self, session: Session, burst: Burst) -> None:
        for _ in range(BURST_PER_STEP):
            template = Payload(burst.seq, 0, Opcode.BURST_READ_FILE, 0, 0, 0, burst.offset, b"")
            if burst.offset >= session.size:
                packet = reply(template, Opcode.NAK, nak_data(Nak.EOF), seq=burst.seq)
                self.burst = None
            else:
                try:
                    session.handle.seek(burst.offset)
                    data = session.handle.read(min(MAX_DATA, session.size - burst.offset))
                except OSError as exc:
                    data, failure = b"", exc
                else:
                    failure = None
                if failure is not None or not data:
                    packet = reply(template, Opcode.NAK, nak_for(failure) if failure else nak_data(Nak.EOF),
                                   seq=burst.seq)  # fmt: skip
                    self.burst = None
                else:
                    burst.sent += len(data)
                    complete = burst.sent >= BURST_BYTES or burst.offset + len(data) >= session.size
                    packet = reply(template, Opcode.ACK, data, seq=burst.seq, burst_complete=int(complete))
                    burst.offset += len(data)
                    if complete:
                        self.burst = None
            burst.seq = (burst.seq + 1) & 0xFFFF
            self._send(session.link, session.client, packet)
            if self.burst is None:
                return

    def _write(self, request: Payload) -> Payload:
        session = self._session(request)
        if session is None or not session.writable:
            return self._nak(request, nak_data(Nak.INVALID_SESSION))
        if request.offset + request.size > MAX_FILE_BYTES:
            return self._nak(request, nak_data(Nak.FAIL_ERRNO, errno.EFBIG))
        session.handle.seek(request.offset)
        written = session.handle.write(request.data[: request.size])
        session.handle.flush()
        return reply(request, Opcode.ACK, written.to_bytes(4, "little"))

    def _terminate(self, request: Payload) -> Payload:
        if self.session is None or request.session != 0:
            return self._nak(request, nak_data(Nak.INVALID_SESSION))
        self._close_session()
        return reply(request, Opcode.ACK)

    def _reset(self, request: Payload) -> Payload:
        self._close_session()
        return reply(request, Opcode.ACK)

    def _close_session(self) -> None:
        if self.session is not None:
            try:
                self.session.handle.close()
            except OSError:
                pass  # a write the disk refused was answered by its NAK already
            self.session = None
        self.burst = None

    def _list(self, request: Payload) -> Payload:
        path = self.root.resolve(request.text)
        entries = sorted(os.scandir(path), key=lambda entry: entry.name)
        data = bytearray()
        for entry in entries[request.offset :]:
            item = _dirent(entry)
            if len(data) + len(item) > MAX_DATA:
                break
            data += item
        if request.offset > 0 and not data:
            return self._nak(request, nak_data(Nak.EOF))
        return reply(request, Opcode.ACK, bytes(data))

    def _remove_file(self, request: Payload) -> Payload:
        path = self.root.resolve(request.text)
        self.root.writable(path)
        if self.session is not None and self.session.path == path:
            self._close_session()
        os.unlink(path)
        return reply(request, Opcode.ACK)

    def _create_directory(self, request: Payload) -> Payload:
        path = self.root.resolve(request.text)
        os.mkdir(path)
        return reply(request, Opcode.ACK)

    def _remove_directory(self, request: Payload) -> Payload:
        path = self.root.resolve(request.text)
        self.root.writable(path)
        os.rmdir(path)
        return reply(request, Opcode.ACK)

    def _truncate(self, request: Payload) -> Payload:
        path = self.root.resolve(request.text)
        self.root.writable(path)
        if request.offset > MAX_FILE_BYTES:
            return self._nak(request, nak_data(Nak.FAIL_ERRNO, errno.EFBIG))
        if not os.path.isfile(path):
            raise OSError(errno.ENOENT if not os.path.lexists(path) else errno.EISDIR, "not a file")
        os.truncate(path, request.offset)
        return reply(request, Opcode.ACK)

    def _rename(self, request: Payload) -> Payload:
        raw = request.data[: min(request.size, MAX_DATA)]
        old, separator, new = raw.partition(b"\0")
        new = new.split(b"\0", 1)[0]
        if not separator or not new:
            return self._nak(request, nak_data(Nak.FAIL_ERRNO, errno.EINVAL))
        source, target = self.root.resolve(old), self.root.resolve(new)
        self.root.writable(source)
        self.root.writable(target)
        os.rename(source, target)
        return reply(request, Opcode.ACK)

    def _crc32(self, request: Payload) -> Payload:
        path = self.root.resolve(request.text)
        checksum = 0
        with open(path, "rb") as handle:
            while block := handle.read(CRC_BLOCK):
                checksum = crc32_update(checksum, block)
        return reply(request, Opcode.ACK, checksum.to_bytes(4, "little"))

    # ---- sending ------------------------------------------------------------------------------------------------
    def _send(self, link: GroundLink, client: tuple[int, int], payload: Payload) -> None:
        link.queue(link.mav.file_transfer_protocol_encode(0, client[0], client[1], payload.encode()))

    def summary(self) -> dict:
        return {"requests": self.requests, "naks": self.naks}


def _dirent(entry: os.DirEntry) -> bytes:
    """A listing entry as PX4 sends it: F<name>\\t<size>, D<name>, or S for what is neither (links, devices)."""
    try:
        if entry.is_symlink():
            return b"S\0"
        if entry.is_file(follow_symlinks=False):
            return b"F" + entry.name.encode("utf-8", "replace") + b"\t" + str(entry.stat().st_size).encode() + b"\0"
        if entry.is_dir(follow_symlinks=False):
            return b"D" + entry.name.encode("utf-8", "replace") + b"\0"
    except OSError:
        pass  # vanished while listed: skipped, as PX4 skips what it cannot stat
    return b"S\0"
