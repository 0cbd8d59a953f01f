"""The seeded UDP fault proxy itself (tiltrotor_sitl/fault_proxy.py): loss, duplication, reordering, delay, counted."""

from __future__ import annotations

import socket
import threading
import time

from tiltrotor_sitl.fault_proxy import DOWNSTREAM, UPSTREAM, FaultProxy, Faults
from transport.ports import LOOPBACK


def exchange(faults: Faults, count: int, seed: int = 3) -> tuple[list[int], dict[str, dict[str, int]]]:
    """Send `count` numbered datagrams through a proxy to a socket that echoes them (a thread); what came back,
    in order. Sent in bursts of 20 so that no socket buffer overflows."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as echo, \
            socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as client:  # fmt: skip
        echo.bind((LOOPBACK, 0))
        client.bind((LOOPBACK, 0))
        echo.settimeout(0.5)
        client.settimeout(0.5)

        def echo_all() -> None:
            while True:
                try:
                    data, sender = echo.recvfrom(100)
                except TimeoutError:
                    return
                echo.sendto(data, sender)

        echoer = threading.Thread(target=echo_all)
        echoer.start()
        back: list[int] = []
        with FaultProxy(echo.getsockname()[1], faults, Faults(), seed=seed) as proxy:
            client.setblocking(False)
            for i in range(count):
                client.sendto(i.to_bytes(4, "big"), (LOOPBACK, proxy.port))
                if i % 20 == 19:
                    time.sleep(0.003)
                    back.extend(drain(client))
            client.settimeout(0.5)
            while True:
                try:
                    back.append(int.from_bytes(client.recvfrom(100)[0], "big"))
                except TimeoutError:
                    break
            echoer.join()
            return back, proxy.summary()


def drain(sock: socket.socket) -> list[int]:
    out: list[int] = []
    while True:
        try:
            out.append(int.from_bytes(sock.recvfrom(100)[0], "big"))
        except BlockingIOError:
            return out


def test_loss_duplication_and_reordering_are_seeded_and_counted():
    faults = Faults(loss=0.1, duplicate=0.05, reorder=0.05, jitter_s=0.001)
    back, summary = exchange(faults, 2000)
    up = summary[UPSTREAM]
    assert up["received"] == 2000 and up["send_failed"] == 0
    assert 150 < up["lost"] < 250 and 60 < up["duplicated"] < 150 and up["reordered"] > 40
    assert up["sent"] == 2000 - up["lost"] + up["duplicated"] == len(back)
    assert summary[DOWNSTREAM]["received"] == summary[DOWNSTREAM]["sent"] == len(back)
    assert len(set(back)) == 2000 - up["lost"]
    assert sum(1 for a, b in zip(back, back[1:]) if b < a) > 20  # out of order
    again, summary_again = exchange(faults, 2000)
    assert summary_again[UPSTREAM]["lost"] == up["lost"]  # the same seed, the same faults


def test_a_clean_proxy_passes_everything_in_order_and_delay_is_applied():
    back, summary = exchange(Faults(), 500)
    assert back == list(range(500)) and summary[UPSTREAM]["sent"] == 500
    start = time.monotonic()
    back, _ = exchange(Faults(delay_s=0.2), 1)
    assert back == [0] and time.monotonic() - start > 0.2
