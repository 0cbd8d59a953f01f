"""The lockstep wait's spin gate (transport/udp.py): it spins only while a core is spare."""

from __future__ import annotations

import sys

import pytest

from transport.udp import SpinGate, running_threads, spare_core, usable_cpus


def test_a_core_is_spare_while_fewer_threads_than_cores_run_besides_the_waiting_one() -> None:
    assert spare_core(running_threads=1, cpus=1)  # only the waiting one
    assert spare_core(running_threads=2, cpus=2)  # it and its peer on two cores: one lockstep pair
    assert not spare_core(running_threads=3, cpus=2)  # a second pair's working side, or a third process
    assert not spare_core(running_threads=2, cpus=1)


class Counter:
    """Runnable-thread counts handed out in turn, and how often they were asked for."""

    def __init__(self, *counts: int | None) -> None:
        self.counts = list(counts)
        self.asked = 0

    def __call__(self) -> int | None:
        self.asked += 1
        return self.counts.pop(0)


def test_the_gate_counts_again_only_after_its_period() -> None:
    counter = Counter(2, 5, 2)
    gate = SpinGate(cpus=2, count_running=counter, period_s=0.05)
    assert gate.open(10.0)
    assert gate.open(10.04) and counter.asked == 1  # within the period: the last answer
    assert not gate.open(10.05)  # counted again: 4 others on 2 cores
    assert not gate.open(10.09) and counter.asked == 2
    assert gate.open(10.2) and counter.asked == 3


def test_the_gate_stays_open_where_threads_cannot_be_counted() -> None:
    assert SpinGate(cpus=2, count_running=Counter(None)).open(0.0)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc/loadavg is Linux's")
def test_the_machines_runnable_threads_include_the_caller() -> None:
    running = running_threads()
    assert running is not None and running >= 1
    assert usable_cpus() >= 1
