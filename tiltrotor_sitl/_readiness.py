"""Ready to arm, as PX4 reports it and as QGroundControl and MAVSDK check it: a HEARTBEAT past MAV_STATE_BOOT,
HOME_POSITION known, and SYS_STATUS health with the pre-arm check bit set.

The watcher only listens, on the UDP port where a vehicle's GCS link sends until a ground station speaks: it never
speaks (a client that speaks becomes the link's client, and the vehicle would stop sending to that port). It is
closed before the caller's ground station binds the same port.
"""

from __future__ import annotations

import select
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass

from transport.mavlink import Link, mavlink
from transport.ports import LOOPBACK

AUTOPILOT_COMPONENT = 1


@dataclass
class Seen:
    """What one system id has shown so far."""

    heartbeat: bool = False
    home: bool = False
    healthy: bool = False

    @property
    def ready(self) -> bool:
        return self.heartbeat and self.home and self.healthy

    def missing(self) -> str:
        parts = [name for name, ok in (("HEARTBEAT past BOOT", self.heartbeat), ("HOME_POSITION", self.home),
                                       ("SYS_STATUS pre-arm check", self.healthy)) if not ok]  # fmt: skip
        return ", ".join(parts) or "nothing"


class ReadinessWatch:
    """A passive listener on 127.0.0.1:`ports` for the vehicles `system_ids`. Raises OSError if a port is taken."""

    def __init__(self, ports: list[int], system_ids: list[int]) -> None:
        self.ports = ports
        self.seen = {system_id: Seen() for system_id in system_ids}
        self._link = Link(255, 190)
        self.sockets: list[socket.socket] = []
        try:
            for port in ports:
                sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                self.sockets.append(sock)
                sock.bind((LOOPBACK, port))
                sock.setblocking(False)
        except OSError:
            self.close()
            raise

    def close(self) -> None:
        for sock in self.sockets:
            sock.close()

    def _note(self, message: mavlink.MAVLink_message) -> None:
        seen = self.seen.get(message.get_srcSystem())
        if seen is None or message.get_srcComponent() != AUTOPILOT_COMPONENT:
            return
        kind = message.get_type()
        if kind == "HEARTBEAT":
            seen.heartbeat = message.system_status != mavlink.MAV_STATE_BOOT
        elif kind == "HOME_POSITION":
            seen.home = True
        elif kind == "SYS_STATUS":
            seen.healthy = bool(message.onboard_control_sensors_health & mavlink.MAV_SYS_STATUS_PREARM_CHECK)

    def ready(self) -> bool:
        return all(seen.ready for seen in self.seen.values())

    def wait(self, timeout_s: float, keep_going: Callable[[], None]) -> bool:
        """Read until every vehicle is ready (True) or `timeout_s` passes (False); `keep_going()` is called between
        reads and may raise (a process that died)."""
        deadline = time.monotonic() + timeout_s
        while not self.ready():
            keep_going()
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            readable, _, _ = select.select(self.sockets, [], [], min(left, 0.1))
            for sock in readable:
                while True:
                    try:
                        data = sock.recv(65536)
                    except BlockingIOError:
                        break
                    for message in self._link.parse(data):
                        self._note(message)
        return True

    def missing(self) -> str:
        """What each vehicle that is not ready has not shown yet."""
        return "; ".join(f"system id {system_id}: no {seen.missing()}"
                         for system_id, seen in self.seen.items() if not seen.ready)  # fmt: skip
