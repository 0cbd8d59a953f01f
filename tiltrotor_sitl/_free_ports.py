"""Free loopback ports for processes this program starts, handed out so that nothing takes them before the
process binds them.

A port found by binding port 0 and closing the socket again comes from the kernel's ephemeral range, the range
it also draws from for every other socket bound to port 0 or connected without a bind (a pymavlink client, a
zenoh connection). A vehicle's processes bind their ports about a second after they are chosen (their imports),
and in that gap such a socket elsewhere could take one. So ports are chosen below the ephemeral range, where the
kernel never hands out a port by itself, and every choice is written into a lease file shared by all the
programs of this user on this machine: a port stays leased for `LEASE_S` seconds, and no other caller gets it
meanwhile. A candidate is also bound once before it is given, so a port some process holds is never chosen.
"""

from __future__ import annotations

import fcntl
import os
import random
import socket
import tempfile
import time
from collections.abc import Iterable
from pathlib import Path

from transport.ports import LOOPBACK, zenoh_endpoint

LEASE_S = 60.0  # far longer than a process takes to start and bind
POOL_FLOOR = 20000  # above every default port of every instance (transport/ports.py: at most 19569)
POOL_CEILING = 65535
DEFAULT_EPHEMERAL = (32768, 60999)  # Linux's default net.ipv4.ip_local_port_range
MIN_POOL = 1000
TRIES = 200  # candidates tried, in random order, before giving up


def ephemeral_range(text: str | None = None) -> tuple[int, int]:
    """The kernel's ephemeral port range: Linux's /proc/sys/net/ipv4/ip_local_port_range (or `text` in its
    format, "low high"), or Linux's default where the file is missing or unreadable."""
    if text is None:
        try:
            text = Path("/proc/sys/net/ipv4/ip_local_port_range").read_text()
        except OSError:
            return DEFAULT_EPHEMERAL
    fields = text.split()
    if len(fields) != 2 or not all(field.isdigit() for field in fields):
        return DEFAULT_EPHEMERAL
    low, high = int(fields[0]), int(fields[1])
    return (low, high) if low <= high else DEFAULT_EPHEMERAL


def pool(ephemeral: tuple[int, int]) -> range:
    """The ports to choose from: the larger of the stretches below and above the ephemeral range (from
    POOL_FLOOR), or everything from POOL_FLOOR where neither has MIN_POOL ports."""
    low, high = ephemeral
    below = range(POOL_FLOOR, max(POOL_FLOOR, low))
    above = range(max(POOL_FLOOR, high + 1), POOL_CEILING + 1)
    best = max(below, above, key=len)
    return best if len(best) >= MIN_POOL else range(POOL_FLOOR, POOL_CEILING + 1)


def lease_folder() -> Path:
    """Where the leases are kept: /tmp/tiltrotor-sitl-UID (made private to this user), the same for every program of
    the user whatever its TMPDIR; the temporary directory where there is no /tmp. OSError if it belongs to someone
    else."""
    base = Path("/tmp") if Path("/tmp").is_dir() else Path(tempfile.gettempdir())
    folder = base / f"tiltrotor-sitl-{os.getuid()}"
    folder.mkdir(mode=0o700, exist_ok=True)
    owner = folder.stat().st_uid
    if owner != os.getuid():
        raise OSError(f"{folder} belongs to user {owner}, not to this user ({os.getuid()}): cannot lease ports there")
    return folder


def _read_leases(text: str, now: float) -> dict[tuple[str, int], float]:
    """The unexpired leases in the file's text: lines "udp|tcp PORT EXPIRY" (epoch seconds); others are skipped."""
    leases = {}
    for line in text.splitlines():
        fields = line.split()
        if len(fields) != 3 or fields[0] not in ("udp", "tcp") or not fields[1].isdigit():
            continue
        try:
            expiry = float(fields[2])
        except ValueError:
            continue
        if expiry > now:
            leases[(fields[0], int(fields[1]))] = expiry
    return leases


def bind_error(kind: socket.SocketKind, port: int) -> OSError | None:
    """Why a socket of `kind` could not bind loopback `port` right now, or None if it could (nobody holds it)."""
    with socket.socket(socket.AF_INET, kind) as probe:
        try:
            probe.bind((LOOPBACK, port))
        except OSError as error:
            return error
    return None


def bindable(kind: socket.SocketKind, port: int) -> bool:
    """Whether a socket of `kind` could bind loopback `port` right now (nobody holds it)."""
    return bind_error(kind, port) is None


def protocol(kind: socket.SocketKind) -> str:
    """ "udp" or "tcp"."""
    return "udp" if kind == socket.SOCK_DGRAM else "tcp"


def lease_ports(
    kinds: Iterable[socket.SocketKind],
    folder: Path | None = None,
    candidates: range | None = None,
    lease_s: float = LEASE_S,
) -> list[int]:
    """One free loopback port for each socket kind in `kinds` (SOCK_DGRAM or SOCK_STREAM), all different, leased
    for `lease_s` seconds in the lease file of `folder` (default: `lease_folder()`), drawn from `candidates`
    (default: the pool outside the ephemeral range). OSError if the lease file cannot be used or no free port is
    found."""
    folder = lease_folder() if folder is None else folder
    candidates = pool(ephemeral_range()) if candidates is None else candidates
    leases_path = folder / "ports.leases"
    chosen: list[int] = []
    with open(folder / "ports.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        now = time.time()
        try:
            leases = _read_leases(leases_path.read_text(encoding="ascii", errors="replace"), now)
        except FileNotFoundError:
            leases = {}
        taken = {port for (_, port) in leases}
        for kind in kinds:
            for port in random.sample(candidates, min(TRIES, len(candidates))):
                if port not in taken and bindable(kind, port):
                    break
            else:
                raise OSError(f"no free {protocol(kind).upper()} port on {LOOPBACK} in {candidates.start}.."
                              f"{candidates.stop - 1}: all tried were leased or bound")  # fmt: skip
            taken.add(port)
            chosen.append(port)
            leases[(protocol(kind), port)] = now + lease_s
        # written beside and renamed over, so a full disk or a kill never leaves the leases cut
        fresh = folder / "ports.leases.new"
        fresh.write_text("".join(f"{name} {port} {expiry!r}\n" for (name, port), expiry in leases.items()),
                         encoding="ascii")  # fmt: skip
        os.replace(fresh, leases_path)
    return chosen


def free_udp_port() -> int:
    """A UDP port on the loopback that nobody holds and nobody else will be given for LEASE_S seconds."""
    return lease_ports([socket.SOCK_DGRAM])[0]


def free_tcp_port() -> int:
    """A TCP port on the loopback that nobody holds and nobody else will be given for LEASE_S seconds."""
    return lease_ports([socket.SOCK_STREAM])[0]


def free_zenoh_endpoint() -> str:
    """A zenoh endpoint on a free loopback TCP port."""
    return zenoh_endpoint(free_tcp_port())
