"""The MPC's solve-time statistics are streamed: quantiles within the sketch's stated accuracy of the exact ones,
the maximum and count exact, and the memory held fixed however many solves are added."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from autopilot.mpc.solve_times import SOLVE_TIME_RELATIVE_ACCURACY, SolveTimes


def test_quantiles_are_within_the_stated_accuracy_and_the_maximum_is_exact():
    rng = np.random.default_rng(3)
    samples = np.concatenate((rng.lognormal(np.log(3.2e-4), 0.2, 20_000), [0.0125, 0.0031]))  # a slow tail
    times = SolveTimes()
    assert times.summary_ms() == {"solve_ms_median": None, "solve_ms_p99": None, "solve_ms_max": None}
    for value in samples:
        times.add(float(value))
    for q in (0.5, 0.99):
        exact = float(np.quantile(samples, q, method="lower"))
        assert times.quantile_s(q) == pytest.approx(exact, rel=SOLVE_TIME_RELATIVE_ACCURACY)
    summary = times.summary_ms()
    assert summary["solve_ms_max"] == 12.5 and times.count == samples.size and times.last_s == 0.0031
    assert summary["solve_ms_median"] == pytest.approx(times.quantile_s(0.5) * 1e3)


def test_a_day_of_solves_holds_a_fixed_amount_of_memory():
    rng = np.random.default_rng(4)
    times = SolveTimes()
    for value in rng.lognormal(np.log(3.2e-4), 0.3, 5_000):  # the range of values is what sizes the sketch
        times.add(float(value))
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        for value in rng.lognormal(np.log(3.2e-4), 0.3, 200_000).tolist():  # about 33 simulated minutes at 100 Hz
            times.add(value)
        grown = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    assert grown < 32_768, grown  # new extremes add a few bins; a list of the times would hold 6.4 MB
