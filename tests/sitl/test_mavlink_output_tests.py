"""PX4's output tests through MAVLink (docs/mavlink.md): MAV_CMD_DO_MOTOR_TEST and MAV_CMD_ACTUATOR_TEST
(QGroundControl's Actuators page) drive one output of a disarmed vehicle for their time-out, then release it; the
refusals PX4 gives (armed, COM_MOT_TEST_EN 0, several motors, another throttle type); the pure PWM rules."""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from aircraft.actuators import command_to_pwm
from autopilot.commander.output_tests import motor_pwm, servo_pwm
from tests.sitl.mavlink_sitl import start_sitl
from tests.sitl.test_mavlink_failsafes import set_param
from transport.mavlink import mavlink as M

STREAM_PERIOD_USEC = 50_000  # SERVO_OUTPUT_RAW at 20 Hz (autopilot/mavlink/streams.py)


def pwm_of(message) -> tuple[int, ...]:
    """The 12 outputs of a SERVO_OUTPUT_RAW."""
    return tuple(getattr(message, f"servo{i}_raw") for i in range(1, 13))


def test_motor_and_actuator_tests_drive_one_output_of_a_disarmed_vehicle_for_their_time_out(tmp_path, airframe):
    sitl = start_sitl(tmp_path / "params.json", speed=None)
    try:
        gs = sitl.gs
        gs.connect()

        def released(stream: list, driven: tuple[int, ...]) -> bool:
            """The stream showed `driven`, then the disarmed outputs again (in lockstep a 0.5 s test can come and go
            between two looks at the latest message)."""
            shown = [pwm_of(m) for m in stream]
            return driven in shown and disarmed in shown[shown.index(driven) :]

        def streaming(stream: list) -> bool:
            """Two messages of the stream one period apart: at its full rate (the schedule restarts when our first
            HEARTBEAT arrives), seen before the command so that the last message before the test is recorded."""
            return len(stream) >= 2 and stream[-1].time_usec - stream[-2].time_usec == STREAM_PERIOD_USEC

        def driven_for(stream: list, driven: tuple[int, ...]) -> int:
            """How long (simulated us, from the stream's own time stamps) the outputs were `driven`: from the first
            message showing it to the first one after that shows the disarmed outputs again. Every message is one
            or the other, the driven ones are one run, and none is missing around it."""
            shown = [(m.time_usec, pwm_of(m)) for m in stream]
            assert {pwm for _, pwm in shown} == {disarmed, driven}, shown
            on = [i for i, (_, pwm) in enumerate(shown) if pwm == driven]
            assert on == list(range(on[0], on[-1] + 1)) and on[0] > 0 and on[-1] + 1 < len(shown)
            around = shown[on[0] - 1 : on[-1] + 2]  # from the last message before to the first one after
            assert {b - a for (a, _), (b, _) in pairwise(around)} == {STREAM_PERIOD_USEC}, around
            return shown[on[-1] + 1][0] - shown[on[0]][0]

        gs.wait(lambda: "SERVO_OUTPUT_RAW" in gs.latest, "SERVO_OUTPUT_RAW")
        disarmed = pwm_of(gs.latest["SERVO_OUTPUT_RAW"])
        assert disarmed == tuple(command_to_pwm(airframe, np.zeros(12)))  # rotors off, tilts up, surfaces centred
        # QGroundControl's motor slider: motor 2 at 30 % for 1 s (DO_MOTOR_TEST, throttle in percent, one motor).
        motor_2 = (disarmed[0], motor_pwm(0.3), *disarmed[2:])  # motor 2 alone, at 1300
        with gs.recording("SERVO_OUTPUT_RAW") as stream:
            gs.wait(lambda: streaming(stream), "SERVO_OUTPUT_RAW at 20 Hz")
            ack = gs.command(M.MAV_CMD_DO_MOTOR_TEST, 2, M.MOTOR_TEST_THROTTLE_PERCENT, 30, 1.0, 1, 0)
            assert ack.result == M.MAV_RESULT_ACCEPTED
            gs.wait(lambda: released(stream, motor_2), "motor 2 at 30 %, then stopped again", 30)
        motor_usec = driven_for(stream, motor_2)
        # ACTUATOR_TEST: servo 1 (tilt servo 1, channel 5) to the end of its range for 0.5 s.
        servo_1 = (*disarmed[:4], servo_pwm(1.0), *disarmed[5:])  # channel 5 alone, at 2000
        with gs.recording("SERVO_OUTPUT_RAW") as stream:
            gs.wait(lambda: streaming(stream), "SERVO_OUTPUT_RAW at 20 Hz")
            ack = gs.command(M.MAV_CMD_ACTUATOR_TEST, 1.0, 0.5, 0, 0, M.ACTUATOR_OUTPUT_FUNCTION_SERVO1, 0, 0)
            assert ack.result == M.MAV_RESULT_ACCEPTED
            gs.wait(lambda: released(stream, servo_1), "servo 1 at its end, then centred again", 30)
        servo_usec = driven_for(stream, servo_1)
        print(f"motor 2 driven {motor_usec} us (time-out 1 s), servo 1 {servo_usec} us (time-out 0.5 s)")
        # In simulated time, from the stream's stamps: a test starts and ends on plant steps, each seen at the next
        # message of the 20 Hz stream, so what is seen is the time-out to within one period (a test that ignored
        # its time-out would run 3 s).
        assert abs(motor_usec - 1_000_000) <= STREAM_PERIOD_USEC and abs(servo_usec - 500_000) <= STREAM_PERIOD_USEC
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
