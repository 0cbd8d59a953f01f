"""A log file written on a background thread, so the control loop never waits for the disk (PX4's logger writes
from a buffer on its own thread too).

The loop hands over chunks of encoded messages; the thread appends them to the file and flushes it. Memory is
bounded: at most MAX_PENDING_BYTES wait; a chunk that would go beyond is dropped, and the next chunk written starts
with a ULog dropout message ('O') saying for how long (in simulated time) samples are missing. A write that fails
(disk full, folder removed) ends the file; the error is kept for the logger to say.
"""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from autopilot.logger import ulog

MAX_PENDING_BYTES = 8 * 1024 * 1024  # what may wait for the disk: about two minutes of this vehicle's log


@dataclass(frozen=True)
class Chunk:
    data: bytes
    first_usec: int  # the simulated time span of its samples (for a dropout's duration)
    last_usec: int


class LogFile:
    """One ULog file being written; `close()` lets the thread finish and close it, `join()` waits for that."""

    def __init__(self, path: Path, handle: BinaryIO) -> None:
        self.path = path
        self._handle = handle
        self._condition = threading.Condition()
        self._pending: deque[Chunk] = deque()
        self._pending_bytes = 0
        self._closing = False
        self.dropped_chunks = 0
        self.written_bytes = 0
        self.error: str | None = None
        self._dropped_usec = 0
        self._thread = threading.Thread(target=self._run, name="ulog-writer", daemon=True)
        self._thread.start()

    @classmethod
    def create(cls, path: Path) -> LogFile:
        """Create the file and its folders (OSError if it cannot be)."""
        path.parent.mkdir(parents=True, exist_ok=True)
        return cls(path, open(path, "xb"))  # noqa: SIM115 (closed by the writer thread)

    def submit(self, chunk: Chunk) -> None:
        with self._condition:
            if self._closing or self.error is not None:
                return
            if self._pending_bytes + len(chunk.data) > MAX_PENDING_BYTES:
                self.dropped_chunks += 1
                self._dropped_usec += max(chunk.last_usec - chunk.first_usec, 1000)
                return
            if self._dropped_usec:
                chunk = Chunk(ulog.dropout(self._dropped_usec // 1000) + chunk.data, chunk.first_usec, chunk.last_usec)
                self._dropped_usec = 0
            self._pending.append(chunk)
            self._pending_bytes += len(chunk.data)
            self._condition.notify()

    def close(self) -> None:
        """No more chunks: the thread writes what waits, then closes the file."""
        with self._condition:
            self._closing = True
            self._condition.notify()

    def join(self, timeout_s: float) -> bool:
        """Wait for the file to be closed; False if it was not within `timeout_s`."""
        self._thread.join(timeout_s)
        return not self._thread.is_alive()

    @property
    def finished(self) -> bool:
        """Closed and all written (or ended by an error)."""
        return not self._thread.is_alive()

    def _run(self) -> None:
        try:
            while True:
                with self._condition:
                    while not self._pending and not self._closing:
                        self._condition.wait()
                    if not self._pending:
                        return
                    chunk = self._pending.popleft()
                    self._pending_bytes -= len(chunk.data)
                self._handle.write(chunk.data)
                self._handle.flush()
                self.written_bytes += len(chunk.data)
        except OSError as exc:
            with self._condition:
                self.error = f"cannot write the log {self.path}: {exc.strerror or exc}"
                self._pending.clear()
                self._pending_bytes = 0
        finally:
            try:
                self._handle.close()
            except OSError as exc:
                self.error = self.error or f"cannot close the log {self.path}: {exc.strerror or exc}"
