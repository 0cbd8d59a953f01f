"""PX4's output tests on the ground (QGroundControl's Actuators page, MAV_CMD_ACTUATOR_TEST; MAV_CMD_DO_MOTOR_TEST):
while the vehicle is disarmed, one output at a time is driven to a test value for up to 3 s, then released.

A test value is what PX4's actuator test takes: a motor's 0 ... 1 is its thrust fraction (PWM 1000 ... 2000, a
negative or NaN value stops it), a servo's -1 ... 1 its whole range (PWM 1000 ... 2000, NaN centres it). The
outputs are the 12 channels of aircraft/actuators.py: motors 1-4 are channels 1-4, servos 1-8 channels 5-12 (the
four tilt servos, then the ailerons, elevator and rudder).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from aircraft.actuators import PWM_MAX, PWM_MIN, ROTORS, SERVO_CHANNELS

MAX_TEST_USEC = 3_000_000  # PX4 limits a test to 3 s, and a test without a time-out lasts that long


@dataclass(frozen=True)
class OutputTest:
    channel: int  # 0 ... 11
    pwm: int
    until_usec: int


def motor_pwm(value: float) -> int:
    """A motor's test value (thrust fraction 0 ... 1; negative or NaN: stopped) as PWM."""
    fraction = min(value, 1.0) if math.isfinite(value) and value > 0.0 else 0.0
    return int(round(PWM_MIN + fraction * (PWM_MAX - PWM_MIN)))


def servo_pwm(value: float) -> int:
    """A servo's test value (-1 ... 1 over its range; NaN: centred) as PWM."""
    position = max(-1.0, min(value, 1.0)) if math.isfinite(value) else 0.0
    return int(round((PWM_MIN + PWM_MAX) / 2 + position * (PWM_MAX - PWM_MIN) / 2))


def duration_usec(timeout_s: float) -> int:
    """PX4's rule: a time-out of 0 (or none) or beyond 3 s is 3 s."""
    usec = int(round(timeout_s * 1e6)) if math.isfinite(timeout_s) else 0
    return MAX_TEST_USEC if usec <= 0 or usec > MAX_TEST_USEC else usec


class OutputTests:
    """The tests running, by channel; `applied` lays them over the disarmed outputs."""

    def __init__(self) -> None:
        self._tests: dict[int, OutputTest] = {}

    def drive(self, motor: bool, index: int, value: float | None, timeout_s: float, now_usec: int) -> None:
        """Motor `index` (0 ... 3) or servo `index` (0 ... 7) at `value` for the time-out; None releases it."""
        channel = (ROTORS.start if motor else SERVO_CHANNELS.start) + index
        if value is None:
            self._tests.pop(channel, None)
            return
        pwm = motor_pwm(value) if motor else servo_pwm(value)
        self._tests[channel] = OutputTest(channel, pwm, now_usec + duration_usec(timeout_s))

    def clear(self) -> None:
        self._tests.clear()

    @property
    def running(self) -> bool:
        return bool(self._tests)

    def applied(self, pwm: list[int], now_usec: int) -> list[int]:
        """`pwm` with the tests that have not timed out laid over it (a new list; `pwm` itself when none run)."""
        for channel in [c for c, test in self._tests.items() if now_usec >= test.until_usec]:
            del self._tests[channel]
        if not self._tests:
            return pwm
        tested = list(pwm)
        for test in self._tests.values():
            tested[test.channel] = test.pwm
        return tested
