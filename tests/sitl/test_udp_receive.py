"""The lockstep wait on loopback sockets (transport/udp.py): with no spare core it blocks instead of spinning."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator

import pytest

from transport.udp import SpinGate, receive


@pytest.fixture
def pair() -> Iterator[tuple[socket.socket, socket.socket]]:
    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        receiver.bind(("127.0.0.1", 0))
        receiver.setblocking(False)
        yield receiver, sender
    finally:
        receiver.close()
        sender.close()


def wait_for_late_datagram(pair: tuple[socket.socket, socket.socket], gate: SpinGate) -> tuple[bytes, float]:
    """A datagram sent 0.3 s into a wait allowed to spin for 1 s: what arrived and the CPU seconds the wait used."""
    receiver, sender = pair
    timer = threading.Timer(0.3, lambda: sender.sendto(b"state", receiver.getsockname()))
    cpu_before = time.process_time()
    timer.start()
    deadline = time.monotonic() + 5.0
    try:
        while (received := receive(receiver, deadline, spin_s=1.0, gate=gate)) is None:
            assert time.monotonic() < deadline, "the datagram never came"  # a blocking wait returns each 0.25 s
    finally:
        timer.join()
    return received[0], time.process_time() - cpu_before


def test_with_no_spare_core_the_wait_blocks(pair: tuple[socket.socket, socket.socket]) -> None:
    busy = SpinGate(cpus=2, count_running=lambda: 8)
    data, cpu_s = wait_for_late_datagram(pair, busy)
    assert data == b"state"
    assert cpu_s < 0.1  # blocked in select: a spin would have used most of the 0.3 s


def test_with_a_spare_core_the_wait_spins(pair: tuple[socket.socket, socket.socket]) -> None:
    idle = SpinGate(cpus=2, count_running=lambda: 1)
    data, cpu_s = wait_for_late_datagram(pair, idle)
    assert data == b"state"
    assert cpu_s > 0.0  # polled (the yield gives the core away to any runnable peer, so how much varies)
