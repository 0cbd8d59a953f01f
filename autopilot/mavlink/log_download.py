"""Log download, as PX4's mavlink log handler serves it (QGroundControl's Log Download page, MAVSDK's log_files):

    LOG_REQUEST_LIST(start, end)      LOG_ENTRY for each log from start to end (0xFFFF: to the last): id (0 is the
                                      oldest), num_logs, last_log_num, size (bytes), time_utc (its modification
                                      time); no logs: one LOG_ENTRY with num_logs 0
    LOG_REQUEST_DATA(id, ofs, count)  LOG_DATA of up to 90 bytes from ofs, count bytes (0xFFFFFFFF: to the end);
                                      at or past the end one LOG_DATA with count 0
    LOG_REQUEST_END                   stops sending
    LOG_ERASE                         removes every log (and their day folders)

The list is taken at LOG_REQUEST_LIST (a log being written is in it with its size then, as in PX4, which serves logs
while armed too), or as soon as a log just ended is all on disk (within SETTLE_S), so a log asked for right after
disarming is listed whole; LOG_REQUEST_DATA refers to that list. Entries and data go out on the link they were asked on,
PER_STEP messages a plant step, so a download never holds the control loop up.
"""

from __future__ import annotations

import os
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import BinaryIO

from autopilot.mavlink.commands import for_us
from autopilot.mavlink.router import GroundLink
from autopilot.storage.vehicle_files import LogEntry, VehicleFiles

DATA_BYTES = 90  # LOG_DATA.data
ENTRIES_PER_STEP = 16
DATA_PER_STEP = 16  # about 1.8 kB a plant step
ALL = 0xFFFF
TO_THE_END = 0xFFFFFFFF
SETTLE_S = 2.0  # wall clock: how long a listing waits for a log just ended to be written


@dataclass
class ListRequest:
    link: GroundLink
    start: int
    end: int
    deadline_s: float  # time.monotonic()


@dataclass
class Listing:
    link: GroundLink
    next_id: int
    last_id: int


@dataclass
class Transfer:
    """A log being sent: its file stays open from chunk to chunk; offset..end is what is left of the chunk."""

    link: GroundLink
    log_id: int
    handle: BinaryIO
    offset: int
    end: int  # exclusive


class LogDownloadService:
    def __init__(self, files: VehicleFiles, *, system_id: int, finishing: Callable[[], bool] = lambda: False) -> None:
        """finishing: True while a log that has ended is still being written to disk (the logger's)."""
        self.files = files
        self.system_id = system_id
        self.finishing = finishing
        self.asked: ListRequest | None = None
        self.entries: list[LogEntry] | None = None  # as listed at the last LOG_REQUEST_LIST
        self.listing: Listing | None = None
        self.transfer: Transfer | None = None

    def on_request_list(self, link: GroundLink, message) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            return
        self._stop_sending()
        self.listing = None
        self.asked = ListRequest(link, message.start, message.end, time.monotonic() + SETTLE_S)
        self._list_when_written(self.asked)

    def _list_when_written(self, asked: ListRequest) -> None:
        if self.finishing() and time.monotonic() < asked.deadline_s:
            return
        self.asked = None
        self.entries = self.files.logs()
        count = len(self.entries)
        if count == 0:
            asked.link.queue(asked.link.mav.log_entry_encode(0, 0, 0, 0, 0))
            return
        last = count - 1 if asked.end == ALL else min(asked.end, count - 1)
        first = min(asked.start, count - 1)
        self.listing = Listing(asked.link, first, max(first, last))

    def on_request_data(self, link: GroundLink, message) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            return
        if self.entries is None or message.id >= len(self.entries):
            return  # PX4 ignores a request for a log it has not listed
        self.listing = self.asked = None
        transfer = self.transfer
        if transfer is None or transfer.log_id != message.id:
            self._stop_sending()
            try:
                handle = open(self.entries[message.id].path, "rb")  # noqa: SIM115 (closed when the transfer ends)
            except OSError:  # erased meanwhile: nothing to send
                link.queue(link.mav.log_data_encode(message.id, message.ofs, 0, bytes(DATA_BYTES)))
                return
            transfer = self.transfer = Transfer(link, message.id, handle, 0, 0)
        size = os.fstat(transfer.handle.fileno()).st_size
        count = size if message.count == TO_THE_END else message.count
        transfer.link, transfer.offset, transfer.end = link, message.ofs, min(size, message.ofs + count)
        if message.ofs >= size:
            link.queue(link.mav.log_data_encode(message.id, message.ofs, 0, bytes(DATA_BYTES)))

    def on_request_end(self, link: GroundLink, message) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            return
        self.listing = self.asked = None
        self._stop_sending()

    def on_erase(self, link: GroundLink, message) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            return
        self.listing = self.asked = None
        self._stop_sending()
        self.entries = None
        for entry in self.files.logs():
            try:
                entry.path.unlink()
            except FileNotFoundError:
                pass  # removed meanwhile: what was asked for
        for day in self._day_folders():
            shutil.rmtree(day, ignore_errors=True)

    def send(self) -> None:
        """Once per plant step: a listing asked for, the next entries of a listing, the next data of a download."""
        if self.asked is not None:
            self._list_when_written(self.asked)
        if self.listing is not None:
            self._send_entries(self.listing)
        if self.transfer is not None and self.transfer.offset < self.transfer.end:
            self._send_data(self.transfer)

    def close(self) -> None:
        self._stop_sending()

    def _send_entries(self, listing: Listing) -> None:
        entries = self.entries or []
        link = listing.link
        for _ in range(ENTRIES_PER_STEP):
            entry = entries[listing.next_id]
            link.queue(link.mav.log_entry_encode(listing.next_id, len(entries), listing.last_id, entry.time_utc,
                                                 entry.size))  # fmt: skip
            if listing.next_id >= listing.last_id:
                self.listing = None
                return
            listing.next_id += 1

    def _send_data(self, transfer: Transfer) -> None:
        """The next LOG_DATA of the chunk asked for; the file stays open for the next chunk (MAVSDK asks for a log
        chunk by chunk)."""
        link = transfer.link
        for _ in range(DATA_PER_STEP):
            transfer.handle.seek(transfer.offset)
            data = transfer.handle.read(min(DATA_BYTES, transfer.end - transfer.offset))
            if not data:  # the file shrank (truncated meanwhile)
                transfer.end = transfer.offset
                return
            link.queue(link.mav.log_data_encode(transfer.log_id, transfer.offset, len(data),
                                                data.ljust(DATA_BYTES, b"\0")))  # fmt: skip
            transfer.offset += len(data)
            if transfer.offset >= transfer.end:
                return

    def _stop_sending(self) -> None:
        if self.transfer is not None:
            self.transfer.handle.close()
        self.transfer = None

    def _day_folders(self) -> list[str]:
        try:
            return [entry.path for entry in os.scandir(self.files.log_dir) if entry.is_dir(follow_symlinks=False)]
        except OSError:
            return []
