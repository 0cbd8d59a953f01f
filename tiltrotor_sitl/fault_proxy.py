"""A seeded UDP fault proxy on the loopback (docs/faults.md): it sits between clients and one UDP endpoint and
loses, duplicates, reorders, delays and jitters datagrams, each direction with its own `Faults`, and counts what
it did.

    with FaultProxy(target_port=plant_port, upstream=Faults(loss=0.05, jitter_s=0.005), seed=1) as proxy:
        ... vtol-autopilot --sim-port {proxy.port} ...   # the autopilot talks to the proxy, the proxy to the plant

Clients send to `proxy.port`; each client address gets its own socket towards the target (so the target sees one
peer per client, as without the proxy, and answers to that socket go back to that client). One thread, one
selector, a heap of datagrams due at a time; `stop()` ends it within POLL_S. Randomness: one random.Random(seed),
so a run's fault pattern depends only on the seed and the order datagrams arrive in.
"""

from __future__ import annotations

import heapq
import random
import selectors
import socket
import threading
import time
from dataclasses import dataclass, field

from transport.ports import LOOPBACK

POLL_S = 0.05  # the longest the thread blocks, so a stop is seen
REORDER_HOLD_S = 0.05  # a datagram held back for reordering goes out after the next one, or after this long
MAX_CLIENTS = 64  # client addresses with their own socket towards the target (oldest dropped beyond)
RECEIVE_SIZE = 65535
UPSTREAM, DOWNSTREAM = "upstream", "downstream"  # client -> target, target -> client


@dataclass(frozen=True)
class Faults:
    """What happens to the datagrams of one direction. Probabilities are per datagram, in 0 … 1."""

    loss: float = 0.0  # dropped
    duplicate: float = 0.0  # sent twice (the copy right after the original)
    reorder: float = 0.0  # held back and sent after the next datagram (or REORDER_HOLD_S later)
    delay_s: float = 0.0  # fixed delay
    jitter_s: float = 0.0  # extra delay, uniform in 0 … jitter_s (delays that cross reorder datagrams too)

    def __post_init__(self) -> None:
        for name, value in (("loss", self.loss), ("duplicate", self.duplicate), ("reorder", self.reorder)):
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"Faults.{name} = {value}: a probability, 0 … 1")
        if not (0.0 <= self.delay_s <= 10.0 and 0.0 <= self.jitter_s <= 10.0):
            raise ValueError(f"Faults: delay {self.delay_s} s and jitter {self.jitter_s} s must be in 0 … 10 s")

    def describe(self) -> str:
        return (f"loss {self.loss:.0%}, dup {self.duplicate:.0%}, reorder {self.reorder:.0%}, "
                f"delay {self.delay_s * 1e3:g} ms + 0-{self.jitter_s * 1e3:g} ms")  # fmt: skip


@dataclass
class DirectionCounters:
    """What the proxy did to one direction's datagrams."""

    received: int = 0
    sent: int = 0
    lost: int = 0
    duplicated: int = 0
    reordered: int = 0
    delayed: int = 0
    send_failed: int = 0

    def as_dict(self) -> dict[str, int]:
        return {"received": self.received, "sent": self.sent, "lost": self.lost, "duplicated": self.duplicated,
                "reordered": self.reordered, "delayed": self.delayed, "send_failed": self.send_failed}  # fmt: skip


@dataclass(order=True)
class _Due:
    at: float
    seq: int
    data: bytes = field(compare=False)
    sock: socket.socket = field(compare=False)
    address: tuple[str, int] = field(compare=False)
    direction: str = field(compare=False)


class FaultProxy:
    """UDP proxy 127.0.0.1:port -> 127.0.0.1:target_port with seeded faults per direction. A context manager."""

    def __init__(self, target_port: int, upstream: Faults = Faults(), downstream: Faults | None = None, *,
                 seed: int = 0, port: int = 0) -> None:  # fmt: skip
        self.target = (LOOPBACK, target_port)
        self._faults = {UPSTREAM: upstream, DOWNSTREAM: upstream if downstream is None else downstream}
        self._random = random.Random(seed)
        self.counters = {UPSTREAM: DirectionCounters(), DOWNSTREAM: DirectionCounters()}
        self.front = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.front.bind((LOOPBACK, port))
        self.front.setblocking(False)
        self.port: int = self.front.getsockname()[1]
        self._backs: dict[tuple[str, int], socket.socket] = {}  # client address -> its socket towards the target
        self._clients: dict[socket.socket, tuple[str, int]] = {}
        self._selector = selectors.DefaultSelector()
        self._selector.register(self.front, selectors.EVENT_READ)
        self._due: list[_Due] = []
        self._held: dict[str, _Due | None] = {UPSTREAM: None, DOWNSTREAM: None}
        self._seq = 0
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"fault-proxy:{self.port}", daemon=True)

    # ---- control ---------------------------------------------------------------------------------------------
    def start(self) -> FaultProxy:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)
        self._selector.close()
        for sock in (self.front, *self._backs.values()):
            sock.close()

    def __enter__(self) -> FaultProxy:
        return self.start()

    def __exit__(self, *_: object) -> None:
        self.stop()

    def set_faults(self, upstream: Faults, downstream: Faults | None = None) -> None:
        """Change the faults while running (e.g. loss=1.0 upstream: the client's datagrams stop arriving)."""
        with self._lock:
            self._faults = {UPSTREAM: upstream, DOWNSTREAM: upstream if downstream is None else downstream}

    def summary(self) -> dict[str, dict[str, int]]:
        with self._lock:
            return {direction: counters.as_dict() for direction, counters in self.counters.items()}

    # ---- the thread --------------------------------------------------------------------------------------------
    def _run(self) -> None:
        while not self._stop.is_set():
            now = time.monotonic()
            wait = POLL_S
            if self._due:
                wait = min(wait, max(0.0, self._due[0].at - now))
            for key, _ in self._selector.select(wait):
                self._read(key.fileobj)  # type: ignore[arg-type]
            self._send_due(time.monotonic())

    def _back_for(self, client: tuple[str, int]) -> socket.socket:
        back = self._backs.get(client)
        if back is None:
            if len(self._backs) >= MAX_CLIENTS:
                oldest, sock = next(iter(self._backs.items()))
                self._selector.unregister(sock)
                del self._backs[oldest], self._clients[sock]
                sock.close()
            back = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            back.bind((LOOPBACK, 0))
            back.setblocking(False)
            self._selector.register(back, selectors.EVENT_READ)
            self._backs[client], self._clients[back] = back, client
        return back

    def _read(self, sock: socket.socket) -> None:
        for _ in range(256):  # bounded per wake-up, so due datagrams are not starved
            try:
                data, sender = sock.recvfrom(RECEIVE_SIZE)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:  # ICMP port unreachable from an earlier send: not data
                continue
            if sock is self.front:
                self._admit(UPSTREAM, data, self._back_for(sender), self.target)
            else:
                self._admit(DOWNSTREAM, data, self.front, self._clients[sock])

    def _admit(self, direction: str, data: bytes, sock: socket.socket, address: tuple[str, int]) -> None:
        rng = self._random
        with self._lock:
            faults = self._faults[direction]
            counters = self.counters[direction]
            counters.received += 1
            if faults.loss and rng.random() < faults.loss:
                counters.lost += 1
                return
            copies = 1
            if faults.duplicate and rng.random() < faults.duplicate:
                counters.duplicated += 1
                copies = 2
            delay = faults.delay_s + (rng.uniform(0.0, faults.jitter_s) if faults.jitter_s else 0.0)
            if delay > 0.0:
                counters.delayed += 1
            hold = bool(faults.reorder) and self._held[direction] is None and rng.random() < faults.reorder
        now = time.monotonic()
        for _ in range(copies):
            self._seq += 1
            due = _Due(now + delay, self._seq, data, sock, address, direction)
            if hold:
                hold = False
                with self._lock:
                    self.counters[direction].reordered += 1
                due.at = now + delay + REORDER_HOLD_S
                self._held[direction] = due
                heapq.heappush(self._due, due)
                continue
            heapq.heappush(self._due, due)
            held = self._held[direction]
            if held is not None and held is not due:  # the held one goes right after this one
                held.at = min(held.at, due.at)
                held.seq = self._seq = self._seq + 1
                heapq.heapify(self._due)
                self._held[direction] = None

    def _send_due(self, now: float) -> None:
        while self._due and self._due[0].at <= now:
            due = heapq.heappop(self._due)
            if self._held[due.direction] is due:
                self._held[due.direction] = None
            try:
                due.sock.sendto(due.data, due.address)
                sent = True
            except OSError:  # nobody listening (ICMP), full buffer
                sent = False
            with self._lock:
                if sent:
                    self.counters[due.direction].sent += 1
                else:
                    self.counters[due.direction].send_failed += 1
