"""Files the autopilot keeps (parameters, missions): replaced atomically, written on a background thread so the
control loop never waits for the disk, and read back at start. A crash or kill -9 at any moment leaves either the
old or the new file, never a broken one."""

from __future__ import annotations

import os
import sys
import threading
from pathlib import Path


def read_kept(path: Path, what: str, refusal: type[ValueError]) -> str | None:
    """The file's text, or None when there is none; temporaries of a writer killed mid-write are removed first.
    A file that cannot be read raises `refusal` ("cannot read the <what> <path>: why")."""
    remove_stale_temporaries(path)
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError) as exc:
        raise refusal(f"cannot read the {what} {path}: {exc}") from None


def remove_stale_temporaries(path: Path) -> None:
    """Temporary files left by a writer that was killed mid-write (the real file is intact)."""
    try:
        for stale in path.parent.glob(f".{path.name}.*.tmp"):
            try:
                stale.unlink()
            except OSError:
                pass
    except OSError:
        pass


def write_atomically(path: Path, text: str) -> None:
    """Replace `path` with `text`: temporary file, fsync, rename over, fsync the folder."""
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.parent / f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp"
    data = text.encode("utf-8")
    fd = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)  # it may hold the signing key
    try:
        view = memoryview(data)
        while view:
            written = os.write(fd, view)
            view = view[written:]
        os.fsync(fd)
    finally:
        os.close(fd)
    try:
        os.replace(temporary, path)
    except OSError:
        temporary.unlink(missing_ok=True)
        raise
    try:
        folder = os.open(path.parent, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(folder)
    except OSError:
        pass
    finally:
        os.close(folder)


class BackgroundWriter:
    """Writes the newest submitted document to `path` on a daemon thread (older unwritten ones are skipped);
    `what` names the file in errors ("parameter file")."""

    def __init__(self, path: Path, what: str) -> None:
        self.path = path
        self.what = what
        self._condition = threading.Condition()
        self._pending: str | None = None
        self._busy = False
        self.last_error: str | None = None
        self.writes = 0
        self._thread: threading.Thread | None = None

    def submit(self, text: str) -> None:
        with self._condition:
            self._pending = text
            if self._thread is None:
                self._thread = threading.Thread(
                    target=self._run, name=self.what.replace(" ", "-") + "-writer", daemon=True
                )
                self._thread.start()
            self._condition.notify_all()

    def _run(self) -> None:
        while True:
            with self._condition:
                while self._pending is None:
                    self._condition.wait()
                text, self._pending = self._pending, None
                self._busy = True
            try:
                write_atomically(self.path, text)
                error = None
            except OSError as exc:
                error = f"cannot write the {self.what} {self.path}: {exc.strerror or exc}"
                print(f"vtol-autopilot: {error}", file=sys.stderr, flush=True)
            with self._condition:
                self._busy = False
                self.last_error = error
                self.writes += 1
                self._condition.notify_all()

    def flush(self, timeout_s: float) -> str | None:
        with self._condition:
            self._condition.wait_for(lambda: self._pending is None and not self._busy, timeout=timeout_s)
            return self.last_error
