"""vtol-autopilot against a fake plant the test controls: whatever the plant sends, the answers are valid PWM;
a silent plant is waited for; garbage is dropped and said (issue 3 "Done means")."""

from __future__ import annotations

import math

NAN = float("nan")


def test_pwm_encoding_never_leaves_its_range(airframe):
    import numpy as np

    from aircraft.actuators import command_to_pwm

    for value in (NAN, math.inf, -math.inf, 1e300, -1e300, 0.5):
        pwm = command_to_pwm(airframe, np.full(12, value))
        assert all(1000 <= p <= 2000 for p in pwm)
    assert command_to_pwm(airframe, np.full(12, NAN))[0:4] == [1000] * 4  # rotors off when not finite
