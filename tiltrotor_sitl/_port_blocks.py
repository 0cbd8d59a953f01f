"""A flight's port block: one instance's ports (transport/ports.py), held by the ground station's socket bound to
the block's API remote port, so flights on one machine claim disjoint blocks without talking to each other.

Instance I's ports belong to no other instance, so whoever has bound instance I's API remote port owns the block
for as long as it keeps the socket; a second claimant finds the port taken and moves on to the next instance.
"""

from __future__ import annotations

import socket
from dataclasses import dataclass

from tiltrotor_sitl._commands import VehiclePorts
from transport.ports import LOOPBACK, MAX_INSTANCE


class NoFreeBlock(RuntimeError):
    """Every instance in the range is held by someone."""


@dataclass
class PortBlock:
    """A vehicle's ports, and the ground station's UDP socket bound where its autopilot's API link sends."""

    ports: VehiclePorts
    ground_station: socket.socket
    instance: int | None = None

    @classmethod
    def bind(cls, ports: VehiclePorts, instance: int | None = None) -> PortBlock:
        """Bind the ground station's socket for `ports`; raises OSError when the port is taken."""
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.bind((LOOPBACK, ports.links.api_remote))
        except OSError:
            sock.close()
            raise
        return cls(ports, sock, instance)

    def close(self) -> None:
        self.ground_station.close()


def claim_block(first: int, count: int, start: int = 0) -> PortBlock:
    """The first instance of `first` .. `first + count - 1`, trying from `first + start % count` on (wrapping),
    whose API remote port nobody holds; raises NoFreeBlock."""
    if not (first >= 0 and count > 0 and first + count - 1 <= MAX_INSTANCE):
        raise ValueError(f"instances {first} .. {first + count - 1} are not within 0 .. {MAX_INSTANCE}")
    for step in range(count):
        instance = first + (start + step) % count
        try:
            return PortBlock.bind(VehiclePorts.of_instance(instance), instance)
        except OSError:
            continue
    raise NoFreeBlock(f"every instance in {first} .. {first + count - 1} is in use")
