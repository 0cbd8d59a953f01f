import math

import numpy as np
import pytest

from aircraft.airframe import load_airframe
from autopilot.control.actuator_health import ServoEstimate


@pytest.fixture(scope="module")
def airframe():
    return load_airframe()


def reference_step(airframe, tilt: float, command: float, stuck: float, scale: float, dt: float) -> float:
    """The servo estimate's law for one servo, as docs/autopilot.md states it, on numpy scalars."""
    target = np.float64(command if math.isnan(stuck) else stuck)
    target = np.clip(target, airframe.tilt_min, airframe.tilt_max)
    limit = airframe.servo_rate_max * np.float64(scale)
    rate = np.clip((target - np.float64(tilt)) / airframe.servo_tau, -limit, limit)
    return float(np.float64(tilt) + rate * dt)


def test_advance_follows_the_law_to_the_last_bit(airframe) -> None:
    servos = ServoEstimate(airframe)
    servos.stuck[2] = math.radians(40.0)
    servos.rate_scale[1] = 0.25
    rng = np.random.default_rng(3)
    for _ in range(300):
        command = rng.uniform(airframe.tilt_min - 0.3, airframe.tilt_max + 0.3, 4)
        dt = float(rng.choice([0.0025, 0.005]))
        expected = [reference_step(airframe, t, c, s, r, dt)
                    for t, c, s, r in zip(servos.tilt, command, servos.stuck, servos.rate_scale)]  # fmt: skip
        assert servos.advance(command, dt).tolist() == expected


def test_any_stuck(airframe) -> None:
    servos = ServoEstimate(airframe)
    assert not servos.any_stuck
    servos.stuck[3] = 0.5
    assert servos.any_stuck
