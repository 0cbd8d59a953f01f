"""Child processes that cannot outlive the test: started in their own process group (a Ctrl-C in the terminal
reaches only the test, which then stops them in order), with PR_SET_PDEATHSIG = SIGKILL on Linux (the kernel kills
them when the process that started them dies, even by SIGKILL), and stopped by PID: SIGTERM, then SIGKILL.

They run with PYTHONHASHSEED fixed (and, as their callers build the command lines, address-space randomisation
off), so two lockstep runs of the same vehicle repeat bit for bit. Their stdout and stderr go to files in the
vehicle's folder (<name>.stdout, <name>.stderr), so a process that dies during start-up can be quoted and a
--summary line read back; a restart appends to the same files.
"""

from __future__ import annotations

import atexit
import json
import signal
import subprocess
import threading
from dataclasses import dataclass
from pathlib import Path

from tiltrotor_sitl._commands import deterministic_environment, die_with_parent

STOP_TIMEOUT_S = 5.0
STDERR_TAIL_LINES = 12

_live: dict[int, subprocess.Popen] = {}  # every child started and not yet reaped, for the atexit safety net
_live_lock = threading.Lock()


@dataclass
class Child:
    """One started process: its name (vtol-sim, vtol-autopilot), command line, Popen, stdout and stderr files."""

    name: str
    argv: list[str]
    process: subprocess.Popen
    stdout_path: Path
    stderr_path: Path

    @property
    def pid(self) -> int:
        return self.process.pid

    def running(self) -> bool:
        return self.process.poll() is None

    def stderr_tail(self, lines: int = STDERR_TAIL_LINES) -> str:
        try:
            text = self.stderr_path.read_text(errors="replace")
        except OSError:
            return ""
        return "\n".join(text.strip().splitlines()[-lines:])

    def describe_exit(self, when: str) -> str:
        tail = self.stderr_tail()
        said = f"; its last stderr lines:\n{tail}" if tail else " (nothing on stderr)"
        return f"{self.name} (pid {self.pid}) exited with code {self.process.returncode} {when}{said}"

    def summary(self) -> dict:
        """The last JSON line on its stdout (the --summary counters printed at its stop), or {} if none yet."""
        try:
            text = self.stdout_path.read_text(errors="replace")
        except OSError:
            return {}
        lines = [line for line in text.splitlines() if line.startswith("{")]
        return json.loads(lines[-1]) if lines else {}

    def restart(self) -> None:
        """Stop it (if running) and start the same command line again, appending to the same files."""
        stop([self])
        self.process = _spawn(self.argv, self.stdout_path, self.stderr_path, "a")


def _spawn(argv: list[str], stdout_path: Path, stderr_path: Path, mode: str) -> subprocess.Popen:
    env = {**deterministic_environment(), "PYTHONUNBUFFERED": "1"}
    with open(stdout_path, mode) as output, open(stderr_path, mode) as errors:
        process = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=output, stderr=errors, env=env,
                                   start_new_session=True, preexec_fn=die_with_parent(signal.SIGKILL))  # fmt: skip
    with _live_lock:
        _live[process.pid] = process
    return process


def start(name: str, argv: list[str], folder: Path) -> Child:
    """Start `argv` as `name` with stdout in folder/<name>.stdout and stderr in folder/<name>.stderr."""
    stdout_path, stderr_path = folder / f"{name}.stdout", folder / f"{name}.stderr"
    return Child(name, argv, _spawn(argv, stdout_path, stderr_path, "w"), stdout_path, stderr_path)


def stop(children: list[Child], timeout_s: float = STOP_TIMEOUT_S) -> None:
    """SIGTERM each child still running, wait for all, SIGKILL what has not stopped after `timeout_s`."""
    for child in children:
        if child.running():
            try:
                child.process.send_signal(signal.SIGTERM)
            except ProcessLookupError:
                pass
    for child in children:
        try:
            child.process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            child.process.kill()
            child.process.wait()
        with _live_lock:
            _live.pop(child.pid, None)


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
