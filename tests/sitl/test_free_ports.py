"""Free ports for started processes (tiltrotor_sitl/_free_ports.py): outside the kernel's ephemeral range, leased so
that no other caller gets them before the process binds them, never a port someone holds."""

from __future__ import annotations

import socket
import time
from pathlib import Path

import pytest

from tiltrotor_sitl._commands import VehiclePorts
from tiltrotor_sitl._free_ports import bindable, ephemeral_range, lease_ports, pool
from transport.ports import LOOPBACK, endpoint_port

UDP, TCP = socket.SOCK_DGRAM, socket.SOCK_STREAM


def test_the_pool_lies_outside_the_ephemeral_range() -> None:
    assert ephemeral_range("32768\t60999\n") == (32768, 60999)
    assert pool((32768, 60999)) == range(20000, 32768)
    assert pool((10000, 30000)) == range(30001, 65536)  # the stretch above
    assert pool((40000, 60999)) == range(20000, 40000)
    assert pool((1024, 65000)) == range(20000, 65536)  # neither stretch is large enough: everything from the floor
    for broken in ("", "abc def", "60999 32768", "1 2 3"):
        assert ephemeral_range(broken) == (32768, 60999)
    low, high = ephemeral_range()
    ports = VehiclePorts.free()
    numbers = [ports.plant, *vars(ports.links).values(), *(endpoint_port(e) for e in
               (ports.zenoh_plant, ports.zenoh_autopilot))]  # fmt: skip
    assert len(set(numbers)) == 7 and not any(low <= port <= high for port in numbers), numbers


# The tests draw from ports below 20000 that no instance uses (transport/ports.py), so vehicles the other tests
# start, whose ports come from the pool, cannot take them.
def test_a_leased_port_is_not_given_again_while_its_lease_lasts(tmp_path: Path) -> None:
    candidates = range(10000, 10200)
    if not all(bindable(kind, port) for port in candidates for kind in (UDP, TCP)):
        pytest.skip("another program holds a port in 10000..10199")
    given = [port for _ in range(100) for port in lease_ports([UDP, TCP], tmp_path, candidates)]
    assert len(set(given)) == 200 and set(given) <= set(candidates)
    assert len((tmp_path / "ports.leases").read_text().splitlines()) == 200
    with pytest.raises(OSError, match="no free UDP port on 127.0.0.1 in 10000..10199"):
        lease_ports([UDP], tmp_path, candidates)
    short = tmp_path / "short"
    short.mkdir()
    first = lease_ports([UDP], short, range(11500, 11501), lease_s=0.2)
    with pytest.raises(OSError):
        lease_ports([UDP], short, range(11500, 11501))
    time.sleep(0.3)
    assert lease_ports([UDP], short, range(11500, 11501)) == first  # expired: free again, and the file pruned
    assert len((short / "ports.leases").read_text().splitlines()) == 1


def test_a_port_someone_holds_is_never_given(tmp_path: Path) -> None:
    for kind in (UDP, TCP):
        with socket.socket(socket.AF_INET, kind) as held:
            held.bind((LOOPBACK, 0))
            port = held.getsockname()[1]
            if not bindable(kind, port + 1):
                pytest.skip(f"another program holds {port + 1}")
            given = {lease_ports([kind], tmp_path, range(port, port + 2), lease_s=0.0)[0] for _ in range(20)}
            assert given == {port + 1}
            with pytest.raises(OSError, match=f"in {port}..{port}: all tried were leased or bound"):
                lease_ports([kind], tmp_path, range(port, port + 1), lease_s=0.0)


def test_a_broken_lease_file_is_read_past(tmp_path: Path) -> None:
    future = time.time() + 600
    broken = b"\n\xff\xfe garbage\nudp abc 1\ntcp 11402 soon\n\n"
    (tmp_path / "ports.leases").write_bytes(b"udp 11401 " + str(future).encode() + broken)
    given = {port for _ in range(3) for port in lease_ports([UDP], tmp_path, range(11400, 11404))}
    assert given == {11400, 11402, 11403}  # 11401's lease holds; the unreadable lines are dropped
    assert "garbage" not in (tmp_path / "ports.leases").read_text()
