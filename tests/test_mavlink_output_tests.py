"""PX4's output tests through MAVLink (docs/mavlink.md section 5): MAV_CMD_DO_MOTOR_TEST and MAV_CMD_ACTUATOR_TEST
(QGroundControl's Actuators page) drive one output of a disarmed vehicle for their time-out, then release it; the
refusals PX4 gives (armed, COM_MOT_TEST_EN 0, several motors, another throttle type); the pure PWM rules."""

from __future__ import annotations

import math

from autopilot.commander.output_tests import MAX_TEST_USEC, OutputTests, duration_usec, motor_pwm, servo_pwm
from tests.mavlink_sitl import start_sitl
from tests.test_mavlink_failsafes import set_param
from transport.mavlink import mavlink as M


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


def test_motor_and_actuator_tests_drive_one_output_of_a_disarmed_vehicle_for_their_time_out(tmp_path):
    sitl = start_sitl(tmp_path / "params.json", speed=None)
    try:
        gs = sitl.gs
        gs.connect()

        def outputs() -> tuple[int, ...]:
            r = gs.latest["SERVO_OUTPUT_RAW"]
            return (r.servo1_raw, r.servo2_raw, r.servo3_raw, r.servo4_raw, r.servo5_raw, r.servo6_raw, r.servo7_raw,
                    r.servo8_raw, r.servo9_raw, r.servo10_raw, r.servo11_raw, r.servo12_raw)  # fmt: skip

        gs.wait(lambda: "SERVO_OUTPUT_RAW" in gs.latest, "SERVO_OUTPUT_RAW")
        disarmed = outputs()
        # QGroundControl's motor slider: motor 2 at 30 % for 1 s (DO_MOTOR_TEST, throttle in percent, one motor).
        ack = gs.command(M.MAV_CMD_DO_MOTOR_TEST, 2, M.MOTOR_TEST_THROTTLE_PERCENT, 30, 1.0, 1, 0)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: outputs()[1] == 1300, "motor 2 at 30 %")
        started = gs.sim_time
        assert outputs()[0] == outputs()[2] == outputs()[3] == 1000  # the others stay stopped
        gs.wait(lambda: outputs()[1] == 1000, "the motor test's end", 30)
        ran = gs.sim_time - started
        # ACTUATOR_TEST: servo 1 (tilt servo 1, channel 5) to the end of its range for 0.5 s.
        ack = gs.command(M.MAV_CMD_ACTUATOR_TEST, 1.0, 0.5, 0, 0, M.ACTUATOR_OUTPUT_FUNCTION_SERVO1, 0, 0)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: outputs()[4] == 2000, "servo 1 at its end")
        gs.wait(lambda: outputs() == disarmed, "the actuator test's end", 30)
        print(f"motor 2 ran {ran:.2f} s (time-out 1 s)")
        # Seen through a 20 Hz stream by a ground station that reads in batches: up to a few tenths of simulated time
        # late at either end when the machine is busy; a test that ignored its time-out would run 3 s.
        assert 0.5 <= ran <= 1.5
        # Refusals, as PX4's commander gives them.
        unsupported = [(M.MAV_CMD_DO_MOTOR_TEST, (1, 1, 30, 1, 1, 0)),  # throttle as PWM
                       (M.MAV_CMD_DO_MOTOR_TEST, (1, 0, 30, 1, 4, 0)),  # four motors in a row
                       (M.MAV_CMD_ACTUATOR_TEST, (0.5, 1, 0, 0, 200, 0, 0))]  # fmt: skip
        for command, params in unsupported:
            assert gs.command(command, *params).result == M.MAV_RESULT_UNSUPPORTED, (command, params)
        assert gs.command(M.MAV_CMD_DO_MOTOR_TEST, 5, 0, 30, 1, 1, 0).result == M.MAV_RESULT_DENIED  # no motor 5
        set_param(gs, "COM_MOT_TEST_EN", 0)
        assert gs.command(M.MAV_CMD_DO_MOTOR_TEST, 1, 0, 30, 1, 1, 0).result == M.MAV_RESULT_DENIED
        set_param(gs, "COM_MOT_TEST_EN", 1)
        assert gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == M.MAV_RESULT_ACCEPTED
        assert gs.command(M.MAV_CMD_DO_MOTOR_TEST, 1, 0, 30, 1, 1, 0).result == M.MAV_RESULT_DENIED  # armed
    finally:
        sitl.kill()
