"""The one way this project starts, watches and stops its processes (the plant and the autopilot for a Vehicle,
`vtol up`, `vtol scenario`, `vtol fly`, the fault campaign, the benchmarks and the tests): a command line as given,
run as it is or deterministically (tiltrotor_sitl/_commands.py: address-space randomisation off, PYTHONHASHSEED
fixed), in this process's environment with the variables the caller sets, stdin closed, stdout and stderr each to
a file, to a temporary file read back (captured), nowhere, or this process's own (the terminal).

Each child has a parent-death signal on Linux (PR_SET_PDEATHSIG: the kernel signals it when the thread that
started it ends, however that ends, SIGKILL included, so nothing flies on with no one to stop it), and optionally
its own process group (a Ctrl-C in the terminal then reaches only this process, which stops the children in
order). Children are stopped by PID: a signal (SIGTERM unless told), then SIGKILL for whatever has not ended after
a time-out; whatever a caller forgot to stop is killed at interpreter exit.

The processes' `--summary` (one JSON line on stdout when they stop) is read here, by `read_summary`.
"""

from __future__ import annotations

import atexit
import ctypes
import enum
import functools
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from contextlib import ExitStack
from pathlib import Path
from typing import IO

from tiltrotor_sitl._commands import deterministic_argv, deterministic_environment

STOP_TIMEOUT_S = 5.0
STDERR_TAIL_LINES = 12
PR_SET_PDEATHSIG = 1  # Linux prctl(2)

_live: dict[int, subprocess.Popen] = {}  # every child started and not yet ended, for the atexit safety net
_live_lock = threading.Lock()


# ---- children that end with their parent -----------------------------------------------------------------------
@functools.cache
def _prctl() -> Callable[..., int]:
    return ctypes.CDLL(None).prctl


def follow_parent(parent_pid: int, signum: int) -> bool:
    """Ask the kernel to send this process `signum` when its parent ends, however it ends, SIGKILL included (Linux
    PR_SET_PDEATHSIG; it goes when the parent's starting thread ends, so start children from a thread that waits for
    them). Exits at once if the parent `parent_pid` has already ended. False where the request is refused or the
    system has no such request."""
    refused = not sys.platform.startswith("linux") or _prctl()(PR_SET_PDEATHSIG, int(signum), 0, 0, 0) != 0
    if os.getppid() != parent_pid:
        os._exit(1)
    return not refused


def die_with_parent(signum: int = signal.SIGTERM) -> Callable[[], None] | None:
    """A `preexec_fn` for subprocess.Popen: the child gets `signum` when this process ends (`follow_parent`), so a
    `vtol` command killed by SIGKILL leaves no plant or autopilot flying on. SIGTERM lets them stop as on a request.
    None where there is no such request (not Linux): no preexec_fn, the plain spawn."""
    if not sys.platform.startswith("linux"):
        return None
    parent = os.getpid()
    _prctl()  # resolved here: between fork and exec the child only calls it

    def preexec() -> None:
        follow_parent(parent, signum)

    return preexec


# ---- where the output goes -------------------------------------------------------------------------------------
class Stream(enum.Enum):
    """Where a child's stdout or stderr goes when it does not go to a file of the caller's (a Path)."""

    CAPTURE = "captured"  # an anonymous temporary file, read back with Child.stdout_text() / stderr_text()
    DISCARD = "discarded"  # nowhere (/dev/null)
    INHERIT = "inherited"  # this process's own (the terminal)


Output = Path | Stream


def _read_all(file: IO[bytes]) -> str:
    """What a captured stream holds, read without moving the offset the child writes at."""
    chunks, offset = [], 0
    while chunk := os.pread(file.fileno(), 1 << 16, offset):
        chunks.append(chunk)
        offset += len(chunk)
    return b"".join(chunks).decode(errors="replace")


class _Sink:
    """One output stream of a child: where it goes and, captured, the temporary file its current run writes and the
    text its earlier runs wrote (a restart appends, as to a file)."""

    def __init__(self, output: Output) -> None:
        self.output = output
        self._capture: IO[bytes] | None = None
        self._kept = ""

    def target(self, files: ExitStack, append: bool) -> int | IO[bytes] | None:
        """What Popen is given for this stream (a file opened here is closed by `files` once the child has it)."""
        if isinstance(self.output, Path):
            return files.enter_context(open(self.output, "ab" if append else "wb"))
        if self.output is Stream.CAPTURE:
            if self._capture is None:
                self._capture = tempfile.TemporaryFile()  # noqa: SIM115 (closed in keep(), once the child has ended)
            return self._capture
        return subprocess.DEVNULL if self.output is Stream.DISCARD else None

    def text(self, what: str) -> str:
        """Everything written so far; OSError if the file cannot be read, ValueError if the stream is not kept."""
        if isinstance(self.output, Path):
            return self.output.read_text(errors="replace")
        if self.output is not Stream.CAPTURE:
            raise ValueError(f"{what} is not kept: it is {self.output.value}")
        return self._kept + ("" if self._capture is None else _read_all(self._capture))

    def keep(self) -> None:
        """The run has ended: a captured stream's text is kept in memory and its temporary file closed."""
        if self._capture is not None:
            self._kept += _read_all(self._capture)
            self._capture.close()
            self._capture = None


# ---- one child -------------------------------------------------------------------------------------------------
class Child:
    """One started process: its name (vtol-sim, vtol-autopilot ...), command line, Popen and where its output goes.
    Made by `start`."""

    def __init__(self, name: str, argv: Sequence[str], stdout: Output, stderr: Output, env: Mapping[str, str],
                 deterministic: bool, own_group: bool, parent_death: int) -> None:  # fmt: skip
        self.name = name
        self.argv = deterministic_argv(list(argv)) if deterministic else list(argv)
        self._sinks = (_Sink(stdout), _Sink(stderr))
        self._env = dict(env)
        self._deterministic = deterministic
        self._own_group = own_group
        self._parent_death = parent_death
        self.process = self._spawn(append=False)

    def _spawn(self, append: bool) -> subprocess.Popen:
        environment = {**(deterministic_environment() if self._deterministic else os.environ), **self._env}
        try:
            with ExitStack() as files:
                stdout, stderr = (sink.target(files, append) for sink in self._sinks)
                process = subprocess.Popen(self.argv, stdin=subprocess.DEVNULL, stdout=stdout, stderr=stderr,
                                           env=environment, start_new_session=self._own_group,
                                           preexec_fn=die_with_parent(self._parent_death))  # fmt: skip
        except BaseException:
            for sink in self._sinks:  # not started: a captured stream's temporary file is closed
                sink.keep()
            raise
        with _live_lock:
            _live[process.pid] = process
        return process

    def _ended(self) -> None:
        for sink in self._sinks:
            sink.keep()
        with _live_lock:
            _live.pop(self.process.pid, None)

    @property
    def pid(self) -> int:
        """Its process id (of the current run, after a restart)."""
        return self.process.pid

    def poll(self) -> int | None:
        """Its exit code once it has ended (negative: the signal that ended it), else None."""
        code = self.process.poll()
        if code is not None:
            self._ended()
        return code

    def running(self) -> bool:
        """It has not ended."""
        return self.poll() is None

    @property
    def returncode(self) -> int | None:
        """Its exit code once it has ended (as poll()), else None."""
        return self.poll()

    def wait(self, timeout_s: float | None = None) -> int:
        """Its exit code once it has ended; subprocess.TimeoutExpired if it still runs after `timeout_s`."""
        code = self.process.wait(timeout=timeout_s)
        self._ended()
        return code

    def send_signal(self, signum: int) -> None:
        """Signal it if it still runs (Popen's: nothing if it has ended meanwhile)."""
        self.process.send_signal(signum)

    def stdout_text(self) -> str:
        """What it has written on stdout so far (across restarts); ValueError if its stdout is not kept."""
        return self._sinks[0].text(f"{self.name}'s stdout")

    def stderr_text(self) -> str:
        """What it has written on stderr so far (across restarts); ValueError if its stderr is not kept."""
        return self._sinks[1].text(f"{self.name}'s stderr")

    def stderr_line(self, timeout_s: float) -> str:
        """The first line it writes on stderr, once it has written a whole one ("" if it ends first or `timeout_s`
        passes)."""
        deadline = time.monotonic() + timeout_s
        while "\n" not in (text := self.stderr_text()):
            if not self.running() or time.monotonic() > deadline:
                return ""
            time.sleep(0.01)
        return text.split("\n", 1)[0] + "\n"

    def stderr_tail(self, lines: int = STDERR_TAIL_LINES) -> str:
        try:
            text = self.stderr_text()
        except OSError:
            return ""
        return "\n".join(text.strip().splitlines()[-lines:])

    def describe_exit(self, when: str) -> str:
        tail = self.stderr_tail()
        said = f"; its last stderr lines:\n{tail}" if tail else " (nothing on stderr)"
        return f"{self.name} (pid {self.pid}) exited with code {self.returncode} {when}{said}"

    def summary(self) -> dict:
        """Its --summary counters (`read_summary` of its stdout), or {} if it has printed none yet."""
        try:
            text = self.stdout_text()
        except OSError:
            return {}
        return read_summary(text)

    def restart(self) -> None:
        """Stop it (if running) and start the same command line again, its output appended to what it wrote."""
        stop([self])
        self.process = self._spawn(append=True)


def read_summary(stdout: str) -> dict:
    """A process's --summary: the last JSON line (one starting with "{") on its stdout, or {} if there is none."""
    lines = [line for line in stdout.splitlines() if line.startswith("{")]
    return json.loads(lines[-1]) if lines else {}


def start(name: str, argv: Sequence[str], *, stdout: Output, stderr: Output, env: Mapping[str, str] | None = None,
          deterministic: bool = False, own_group: bool = False, parent_death: int = signal.SIGTERM) -> Child:  # fmt: skip
    """Start `argv` as `name`: stdout and stderr to a file (a Path, written from the start) or as `Stream` says; in
    this process's environment with `env`'s variables set over it; `deterministic`: a run that repeats bit for bit
    (deterministic_argv and deterministic_environment); in a process group of its own if `own_group`; sent
    `parent_death` when this process ends."""
    return Child(name, argv, stdout, stderr, env or {}, deterministic, own_group, parent_death)


def stop(children: Sequence[Child], signum: int = signal.SIGTERM, timeout_s: float = STOP_TIMEOUT_S) -> list[Child]:
    """Send `signum` to each child still running, wait for them all until `timeout_s` from now, then SIGKILL those
    still running (and wait for them): returns the ones that had to be killed."""
    for child in children:
        child.send_signal(signum)
    deadline = time.monotonic() + timeout_s
    killed = []
    for child in children:
        try:
            child.wait(max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            child.send_signal(signal.SIGKILL)
            child.wait()
            killed.append(child)
    return killed


def run_to_end(
    argv: Sequence[str], timeout_s: float, env: Mapping[str, str] | None = None
) -> subprocess.CompletedProcess:
    """Run `argv` to its end (`env`'s variables set) with stdout and stderr captured (a command line refused, --help),
    as subprocess.run with capture_output and text does: after `timeout_s` it is killed and
    subprocess.TimeoutExpired raised."""
    child = start(Path(argv[0]).name, argv, stdout=Stream.CAPTURE, stderr=Stream.CAPTURE, env=env)
    try:
        code = child.wait(timeout_s)
    finally:
        stop([child], signal.SIGKILL)
    return subprocess.CompletedProcess(child.argv, code, child.stdout_text(), child.stderr_text())


def _kill_leftovers() -> None:
    """At interpreter exit: whatever a caller forgot to stop (no `with`, no close()) is killed."""
    with _live_lock:
        leftovers = list(_live.values())
        _live.clear()
    for process in leftovers:
        if process.poll() is None:
            process.kill()
            process.wait()


atexit.register(_kill_leftovers)
