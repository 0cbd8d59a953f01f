"""Low-latency UDP receive for the lockstep link.

A blocking receive costs a scheduler wake-up: ~57 us per round trip between two processes on this kind of
machine, against ~11 us when the waiting side polls a non-blocking socket (measured).
In lockstep the answer usually comes within tens of microseconds, so `receive` polls for a short spin
window and only then blocks, which keeps an idle process from burning a core. The poll loop yields the CPU
at each turn: with more runnable processes than cores (a third process, a loaded CI machine) a pure spin
starved the peer it was waiting for (4.5 ms per round trip measured, against 18 us with the yield).

A spinning wait is worth its core only while the machine has one to spare. With two lockstep pairs on two cores
(`vtol scenario --jobs 2`, campaign workers, the test suite's workers) each pair's waiting side kept a core that the
other pair's working side needed. So the spin is gated: it runs only while the runnable threads besides the waiting
one are fewer than the cores (Linux /proc/loadavg, looked at every CORE_CHECK_S); otherwise the wait blocks at once.
"""

from __future__ import annotations

import math
import os
import select
import socket
import sys
import time
from collections.abc import Callable

SPIN_WINDOW_S = 0.002  # poll this long before blocking
MAX_BLOCK_S = 0.25  # longest single blocking wait, so callers can notice a stop request

RECEIVE_SIZE = 65536
CORE_CHECK_S = 0.05  # how often (wall s) the spin gate looks again for a spare core


def spare_core(running_threads: int, cpus: int) -> bool:
    """Whether a core is left for a spinning wait: fewer runnable threads besides the waiting one than cores."""
    return running_threads - 1 < cpus


def running_threads() -> int | None:
    """The machine's runnable threads now, the caller included (the fourth field of Linux's /proc/loadavg,
    "running/total"); None where that cannot be read."""
    try:
        with open("/proc/loadavg", "rb") as file:
            return int(file.read().split()[3].split(b"/")[0])
    except (OSError, ValueError, IndexError):
        return None


def usable_cpus() -> int:
    """The CPUs this process may run on (its affinity where the system has one)."""
    return len(os.sched_getaffinity(0)) if sys.platform == "linux" else os.cpu_count() or 1


class SpinGate:
    """Whether a wait may spin now: while a core is spare, looked at again every `period_s` (wall s). Where the
    runnable threads cannot be counted, always (the spin then yields at each turn, as before the gate)."""

    def __init__(self, cpus: int, count_running: Callable[[], int | None] = running_threads,
                 period_s: float = CORE_CHECK_S) -> None:  # fmt: skip
        self.cpus = cpus
        self.count_running = count_running
        self.period_s = period_s
        self._checked = -math.inf
        self._open = True

    def open(self, now: float) -> bool:
        """May a wait beginning at `now` (time.monotonic) spin."""
        if now - self._checked >= self.period_s:
            self._checked = now
            running = self.count_running()
            self._open = running is None or spare_core(running, self.cpus)
        return self._open


GATE = SpinGate(usable_cpus())


def receive(sock: socket.socket, deadline: float, spin_s: float = SPIN_WINDOW_S,
            gate: SpinGate = GATE) -> tuple[bytes, tuple] | None:  # fmt: skip
    """Next datagram and its sender, or None once `deadline` (time.monotonic) passes; polled for up to `spin_s`
    first while `gate` is open.

    The socket must be non-blocking (`sock.setblocking(False)`, done once). Returns None early after
    MAX_BLOCK_S of blocking, so a caller's loop can check for stop requests. ICMP errors (peer not
    listening) are skipped, not raised.
    """
    now = time.monotonic()
    spin_until = min(deadline, now + spin_s) if spin_s > 0.0 and gate.open(now) else now
    while True:
        try:
            return sock.recvfrom(RECEIVE_SIZE)
        except (BlockingIOError, ConnectionError):
            pass
        if time.monotonic() >= spin_until:
            break
        os.sched_yield()  # give the core to a runnable process (the peer, on a busy machine) while we poll
    remaining = deadline - time.monotonic()
    if remaining <= 0:
        return None
    select.select([sock], [], [], min(remaining, MAX_BLOCK_S))
    try:
        return sock.recvfrom(RECEIVE_SIZE)
    except (BlockingIOError, ConnectionError):
        return None
