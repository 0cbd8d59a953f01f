"""The truth's history (tiltrotor_sitl/truth.py, TruthHistory): every sample kept, queried after the fact, and waits
that see every sample, earlier ones too when asked; fed here with synthetic plant states, as zenoh feeds it."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import pytest

from tiltrotor_sitl.truth import COLUMN, TruthHistory, TruthTimeout
from transport.telemetry import PLANT_STATE_FIELDS

STEP_S = 0.0025


def states(first_step: int, count: int, altitude=lambda t: t) -> np.ndarray:
    """`count` plant states from step `first_step` on: t on the plant's 2.5 ms grid, altitude(t) metres up."""
    rows = np.zeros((count, len(PLANT_STATE_FIELDS)))
    t = (first_step + np.arange(count)) * STEP_S
    rows[:, COLUMN["t"]] = t
    rows[:, COLUMN["down"]] = -np.vectorize(altitude)(t)
    rows[:, COLUMN["qw"]] = 1.0
    return rows


def climb_and_land(t: float) -> float:
    """Up to 8 m at t = 4 s, then down again."""
    return max(0.0, 8.0 - 2.0 * abs(t - 4.0))


def test_every_sample_is_kept_and_queried_after_the_fact() -> None:
    history = TruthHistory(1, "test")
    for first in range(0, 4000, 10):  # 10 s in payloads of 10 steps, as the plant sends them in lockstep
        history.extend(states(first, 10, climb_and_land))
    assert len(history) == 4000
    highest = history.max(lambda s: s.altitude)
    assert highest.altitude == pytest.approx(8.0) and highest.t == pytest.approx(4.0)
    assert history.min(lambda s: s.altitude).t == 0.0  # the first of equals
    assert history.first(lambda s: s.altitude > 5.0).t == pytest.approx(2.5025)
    assert history.first(lambda s: s.altitude > 9.0) is None
    trajectory = history.trajectory()
    assert trajectory.altitude.max() == pytest.approx(8.0)
    assert trajectory.position_ned.shape == (4000, 3) and trajectory.euler.shape == (4000, 3)
    assert np.allclose(trajectory.euler, 0.0) and not trajectory.on_ground.any()
    assert trajectory.sample(1600).altitude == pytest.approx(8.0)


def test_a_mark_lets_go_of_the_samples_before_it() -> None:
    history = TruthHistory(1, "test")
    history.extend(states(0, 400, climb_and_land))
    history.mark()
    assert len(history) == 0
    with pytest.raises(ValueError, match="no plant truth received yet"):
        history.max(lambda s: s.altitude)
    history.extend(states(400, 400, climb_and_land))
    assert history.min(lambda s: s.t).t == pytest.approx(1.0)


@contextmanager
def flying_on(history: TruthHistory, first_step: int) -> Iterator[None]:
    """The plant flying on while the block runs: payloads of 10 steps (25 ms), one each wall millisecond."""
    done = threading.Event()

    def feed() -> None:
        first = first_step
        while not done.wait(0.001):
            history.extend(states(first, 10))
            first += 10

    feeder = threading.Thread(target=feed)
    feeder.start()
    try:
        yield
    finally:
        done.set()
        feeder.join()


def test_a_single_step_before_the_wait_is_found_with_include_past_and_only_then() -> None:
    history = TruthHistory(1, "test")
    history.extend(states(0, 1000))
    one_step = lambda s: abs(s.t - 1.0) < STEP_S / 2  # noqa: E731 (holds at t = 1.0 s alone)
    found = history.wait_until(one_step, timeout_sim_s=1.0, include_past=True)
    assert found.t == pytest.approx(1.0)
    with flying_on(history, 1000), pytest.raises(TruthTimeout, match="did not hold within 1 simulated seconds"):
        history.wait_until(one_step, timeout_sim_s=1.0, timeout_wall_s=30.0)


def test_a_wait_sees_every_sample_of_a_payload_not_only_the_last() -> None:
    history = TruthHistory(1, "test")
    with flying_on(history, 0):
        middle = history.wait_until(lambda s: round(s.t / STEP_S) % 10 == 5, timeout_sim_s=1.0)  # never a last step
    assert round(middle.t / STEP_S) % 10 == 5


def test_waits_give_up_in_wall_time_without_samples_and_say_so() -> None:
    history = TruthHistory(7, "tcp/127.0.0.1:1")
    with pytest.raises(TruthTimeout, match="within 0.1 wall seconds .*vehicle 7, no plant truth received"):
        history.wait_until(lambda s: True, timeout_sim_s=1.0, timeout_wall_s=0.1)
    with pytest.raises(TruthTimeout, match="no plant truth within 0 wall seconds"):
        history.latest(timeout_s=0.0)
