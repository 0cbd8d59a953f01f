"""Free ports for started processes (tiltrotor_sitl/_free_ports.py): outside the kernel's ephemeral range, leased so
that no other caller gets them before the process binds them, never a port someone holds."""

from __future__ import annotations

import multiprocessing
import os
import socket
from pathlib import Path

from tiltrotor_sitl._free_ports import lease_folder, lease_ports

UDP, TCP = socket.SOCK_DGRAM, socket.SOCK_STREAM


def _lease_many(path: str, count: int, queue: multiprocessing.Queue) -> None:
    queue.put([lease_ports([UDP], Path(path), range(10300, 11300))[0] for _ in range(count)])


def test_two_processes_leasing_at_once_get_different_ports(tmp_path: Path) -> None:
    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    workers = [context.Process(target=_lease_many, args=(str(tmp_path), 150, queue)) for _ in range(2)]
    for worker in workers:
        worker.start()
    got = [queue.get(timeout=60) for _ in workers]
    for worker in workers:
        worker.join(timeout=10)
    assert all(len(ports) == 150 for ports in got)
    assert not set(got[0]) & set(got[1]) and len(set(got[0]) | set(got[1])) == 300


def test_the_lease_folder_is_this_users_and_private() -> None:
    folder = lease_folder()
    assert folder.stat().st_uid == os.getuid() and folder.stat().st_mode & 0o077 == 0
    assert folder == lease_folder()  # the same for every caller of this user
