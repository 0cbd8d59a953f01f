"""The failure detector's motor check (autopilot/commander/failure_detector.py) on ESC reports, no processes."""

from __future__ import annotations

import math

import pytest

from autopilot.commander.failure_detector import MotorCheck, MotorFailureDetector, expected_rpm, failing

SPEED_MAX = 1000.0  # rad/s
CHECK = MotorCheck(min_command=0.2, rpm_ratio=0.5, timeout_usec=100_000)
PERIOD = 10_000  # us: the plant's 100 Hz ESC telemetry


def test_the_expected_speed_grows_with_the_square_root_of_the_thrust_fraction():
    assert expected_rpm(1.0, SPEED_MAX) == pytest.approx(SPEED_MAX * 60 / (2 * math.pi))
    assert expected_rpm(0.25, SPEED_MAX) == pytest.approx(expected_rpm(1.0, SPEED_MAX) / 2)
    assert expected_rpm(-0.1, SPEED_MAX) == 0.0


@pytest.mark.parametrize("rpm, command, verdict", [
    (0.0, 0.19, False),  # below FD_ACT_MOT_THR: not checked
    (0.0, math.nan, False),  # no command to compare with: not checked
    (0.0, 0.5, True),  # stopped
    (math.nan, 0.5, True),  # an ESC that cannot tell
    (0.49 * expected_rpm(0.5, SPEED_MAX), 0.5, True),
    (0.51 * expected_rpm(0.5, SPEED_MAX), 0.5, False),
    (2.0 * expected_rpm(0.5, SPEED_MAX), 0.5, False),  # spinning down after a lower command
])  # fmt: skip
def test_a_sample_is_failing_when_a_commanded_rotor_turns_at_less_than_the_ratio(rpm, command, verdict):
    assert failing(rpm, command, SPEED_MAX, CHECK) is verdict


def test_a_rotor_failing_for_the_timeout_is_failed_once_and_the_others_are_not():
    detector = MotorFailureDetector(SPEED_MAX, 4)
    found = []
    for k in range(20):
        t = k * PERIOD
        for index in range(4):
            rpm = 0.0 if index == 1 else expected_rpm(0.5, SPEED_MAX)
            if detector.sample(index, rpm, 0.5, t, CHECK):
                found.append((index, t))
    assert found == [(1, 100_000)] and detector.failed == [1]  # 100 ms after the first stopped sample


def test_a_healthy_sample_restarts_the_timeout_and_a_reset_forgets_the_failure():
    detector = MotorFailureDetector(SPEED_MAX, 4)
    healthy = expected_rpm(0.5, SPEED_MAX)
    assert not detector.sample(0, 0.0, 0.5, 0, CHECK)
    assert not detector.sample(0, healthy, 0.5, 90_000, CHECK)  # a spin-up transient, not a failure
    assert not detector.sample(0, 0.0, 0.5, 100_000, CHECK)
    assert not detector.sample(0, 0.0, 0.5, 190_000, CHECK)
    assert detector.sample(0, 0.0, 0.5, 200_000, CHECK)
    assert not detector.sample(0, 0.0, 0.5, 300_000, CHECK)  # said once
    detector.reset()
    assert detector.failed == [] and not detector.sample(0, 0.0, 0.5, 400_000, CHECK)


def test_an_esc_index_past_the_rotors_is_ignored():
    detector = MotorFailureDetector(SPEED_MAX, 4)
    assert not any(detector.sample(4, 0.0, 1.0, t, CHECK) for t in range(0, 500_000, PERIOD))
    assert detector.failed == []


def test_a_pause_forgets_a_rotor_that_was_failing_so_the_next_flight_starts_its_timeout_afresh():
    detector = MotorFailureDetector(SPEED_MAX, 4)
    assert not detector.sample(2, 0.0, 0.5, 0, CHECK)  # failing at the end of a flight
    detector.pause()  # landed: the check is not running
    assert not detector.sample(2, 0.0, 0.5, 500_000, CHECK)  # the next take-off's spin-up: failing from now only
    assert detector.sample(2, 0.0, 0.5, 600_000, CHECK)
