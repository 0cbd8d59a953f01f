"""The ground-station links: UDP sockets on 127.0.0.1, their clients, and batched sending (a tiny MAVLink router).

    GCS  binds 18570+I, sends to 127.0.0.1:14550 (every instance) until a client speaks, then to its clients
    API  binds 14580+I, sends to 127.0.0.1:14540+I until a client speaks, then to its clients (MAVSDK)

A client is any sender of a valid MAVLink message; a link serves its MAX_CLIENTS most recent ones (so a second
script, or a ground station restarted on another port, is answered too). Frames are batched into datagrams of
about DATAGRAM_LIMIT bytes. Reading is bounded per step (datagrams and time), so a flood cannot starve the
control loop: what is left waits in the socket, and the kernel drops what does not fit.
"""

from __future__ import annotations

import select
import socket
import time
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

from autopilot.mavlink.streams import StreamSchedule, link_rates
from transport.mavlink import Link
from transport.ports import LOOPBACK

COMP_ID = 1
RECEIVE_SIZE = 65536
DATAGRAM_LIMIT = 1200  # bytes: frames are batched into datagrams up to about this size (PX4 batches too)
MAX_CLIENTS = 4  # per link: the most recent distinct senders get the link's traffic
MAX_DATAGRAMS_PER_STEP = 16  # per link and step
MAX_DATAGRAM_BYTES = 4096  # MAVLink over UDP is one or a few frames (<= 280 bytes each) per datagram: bigger is junk


@dataclass
class LinkCounters:
    received: int = 0
    sent_datagrams: int = 0
    send_failed: int = 0
    ignored: Counter[str] = field(default_factory=Counter)


class GroundLink:
    """One UDP MAVLink link to ground stations (GCS or API)."""

    def __init__(self, name: str, bind_port: int, remote_port: int, system_id: int, *, onboard: bool = False,
                 bind_address: str = LOOPBACK) -> None:  # fmt: skip
        """`onboard`: the stream rates of PX4's onboard link (the API link's); `bind_address`: the IPv4 address the
        link listens on (a remote ground station reaches 0.0.0.0 or the machine's own address)."""
        self.name = name
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.bind((bind_address, bind_port))
        except OSError:
            self.sock.close()
            raise
        self.sock.setblocking(False)
        self.bind_address, self.bind_port = self.sock.getsockname()
        self.default_remote = (LOOPBACK, remote_port)
        self.clients: list[tuple[str, int]] = []  # most recent first
        self.link = Link(system_id, COMP_ID)
        self.streams = StreamSchedule(link_rates(onboard))
        self.out = bytearray()
        self.counters = LinkCounters()

    @property
    def mav(self) -> Any:
        """The link's pymavlink encoder (message_encode functions)."""
        return self.link.mav

    def heard(self, sender: tuple[str, int]) -> bool:
        """A valid message from `sender`; True if it is the link's first client."""
        first = not self.clients
        if not self.clients or self.clients[0] != sender:
            if sender in self.clients:
                self.clients.remove(sender)
            self.clients.insert(0, sender)
            del self.clients[MAX_CLIENTS:]
        return first

    def receive(self, deadline: float) -> Iterator[tuple[bytes, tuple[str, int]]]:
        """Datagrams waiting in the socket (sender too), until MAX_DATAGRAMS_PER_STEP or the deadline (perf_counter)."""
        for _ in range(MAX_DATAGRAMS_PER_STEP):
            try:
                data, sender = self.sock.recvfrom(RECEIVE_SIZE)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:  # ICMP "port unreachable" from an earlier send to a closed port: not data
                continue
            if len(data) > MAX_DATAGRAM_BYTES:
                self.link.dropped["oversized_datagram"] += 1
                continue
            yield data, sender
            if time.perf_counter() >= deadline:
                return

    def queue(self, message: Any) -> None:
        self.out += self.link.pack(message)
        if len(self.out) >= DATAGRAM_LIMIT:
            self.flush()

    def flush(self) -> None:
        if not self.out:
            return
        data = bytes(self.out)
        self.out = bytearray()
        for remote in self.clients or (self.default_remote,):
            try:
                self.sock.sendto(data, remote)
                self.counters.sent_datagrams += 1
            except OSError:  # nobody listening (ICMP), full buffer: counted, the flight goes on
                self.counters.send_failed += 1

    def close(self) -> None:
        self.flush()
        self.sock.close()

    def summary(self) -> dict[str, Any]:
        return {
            "port": self.bind_port,
            "clients": [f"{host}:{port}" for host, port in self.clients],
            "received": self.counters.received,
            "sent_datagrams": self.counters.sent_datagrams,
            "send_failed": self.counters.send_failed,
            "dropped": dict(self.link.dropped),
            "ignored": dict(self.counters.ignored),
        }


class Router:
    """The links together: which have datagrams (one poll system call per step), sending to all."""

    def __init__(self, links: list[GroundLink]) -> None:
        self.links = links
        self._poll = select.poll()
        self._by_fd: dict[int, GroundLink] = {}
        for link in links:
            self._poll.register(link.sock, select.POLLIN)
            self._by_fd[link.sock.fileno()] = link

    def ready(self, wait_ms: int) -> list[GroundLink]:
        """The links with datagrams waiting (waiting up to wait_ms for the first)."""
        return [self._by_fd[fd] for fd, _ in self._poll.poll(wait_ms)]

    def queue_all(self, build: Any) -> None:
        """`build(link)` -> a message, queued on every link."""
        for link in self.links:
            link.queue(build(link))

    def flush(self) -> None:
        for link in self.links:
            if link.out:
                link.flush()

    def close(self) -> None:
        for link in self.links:
            link.close()
