"""PX4's output tests through MAVLink (docs/mavlink.md): MAV_CMD_DO_MOTOR_TEST and MAV_CMD_ACTUATOR_TEST
(QGroundControl's Actuators page) drive one output of a disarmed vehicle for their time-out, then release it; the
refusals PX4 gives (armed, COM_MOT_TEST_EN 0, several motors, another throttle type); the pure PWM rules."""

from __future__ import annotations

import math

from autopilot.commander.output_tests import MAX_TEST_USEC, OutputTests, duration_usec, motor_pwm, servo_pwm


def test_test_values_become_pwm_and_tests_end_at_their_time_out():
    assert (motor_pwm(0.3), motor_pwm(-1.0), motor_pwm(math.nan), motor_pwm(2.0)) == (1300, 1000, 1000, 2000)
    assert (servo_pwm(1.0), servo_pwm(-1.0), servo_pwm(math.nan), servo_pwm(0.5)) == (2000, 1000, 1500, 1750)
    assert duration_usec(1.0) == 1_000_000 and duration_usec(0.0) == duration_usec(10.0) == MAX_TEST_USEC
    tests, disarmed = OutputTests(), [1000] * 4 + [1069] * 4 + [1500] * 4
    tests.drive(True, 1, 0.3, 1.0, now_usec=0)
    tests.drive(False, 0, 1.0, 0.5, now_usec=0)
    assert tests.applied(disarmed, 400_000)[1] == 1300 and tests.applied(disarmed, 400_000)[4] == 2000
    assert tests.applied(disarmed, 600_000)[4] == 1069 and tests.applied(disarmed, 600_000)[1] == 1300
    assert tests.applied(disarmed, 1_000_000) is disarmed and not tests.running
    tests.drive(True, 3, 0.5, 1.0, now_usec=0)
    tests.drive(True, 3, None, 0.0, now_usec=0)  # released
    assert tests.applied(disarmed, 0) is disarmed
