"""The commands on the motors' outputs, read into requests (autopilot/commander/output_requests.py judges them):
MAV_CMD_DO_FLIGHTTERMINATION, MAV_CMD_DO_MOTOR_TEST and MAV_CMD_ACTUATOR_TEST. Each function gives the request,
or the reply that refuses the command's parameters."""

from __future__ import annotations

import math

from aircraft.actuators import ROTOR_COUNT, SERVO_COUNT
from autopilot.mavlink.command_params import Params, int_param
from autopilot.topics.requests import FlightTermination, OutputTest, Reply
from transport.mavlink import mavlink as M


def flight_termination(p: Params) -> FlightTermination | Reply:
    """MAV_CMD_DO_FLIGHTTERMINATION (MAVSDK's action.terminate()): param1 > 0.5 terminates (PX4's 1, and its 2, the
    lockdown test, likewise stop the motors here), otherwise clears a termination."""
    if not math.isfinite(p[0]):
        return M.MAV_RESULT_DENIED, "Flight termination denied: param1 not finite"
    return FlightTermination(p[0] > 0.5)


def motor_test(p: Params) -> OutputTest | Reply:
    """MAV_CMD_DO_MOTOR_TEST: param1 motor 1 ... 4, param2 throttle type (only MOTOR_TEST_THROTTLE_PERCENT, as PX4),
    param3 throttle (%), param4 time-out (s, at most 3), param5 motor count (one at a time, as PX4)."""
    motor, kind = int_param(p[0]), int_param(p[1])
    count = int_param(p[4]) if math.isfinite(p[4]) else 0  # NaN: one
    if kind != M.MOTOR_TEST_THROTTLE_PERCENT or count is None or count > 1:
        return M.MAV_RESULT_UNSUPPORTED, "Motor test: only one motor at a time, throttle in percent"
    if motor is None or not 1 <= motor <= ROTOR_COUNT:
        return M.MAV_RESULT_DENIED, f"Motor test denied: param1 (motor) {p[0]:g} not 1..{ROTOR_COUNT}"
    if not math.isfinite(p[2]):
        return M.MAV_RESULT_DENIED, "Motor test denied: param3 (throttle) not finite"
    value = p[2] / 100.0
    return OutputTest(True, motor - 1, value if value > 0.0 else None, p[3])


def actuator_test(p: Params) -> OutputTest | Reply:
    """MAV_CMD_ACTUATOR_TEST (QGroundControl's Actuators page): param1 value (-1 ... 1), param2 time-out (s, at most
    3; 0 or less releases the output), param5 ACTUATOR_OUTPUT_FUNCTION (MOTOR1 ... 4, SERVO1 ... 8)."""
    function = int_param(p[4])
    motor = function is not None and 0 <= function - M.ACTUATOR_OUTPUT_FUNCTION_MOTOR1 < ROTOR_COUNT
    servo = function is not None and 0 <= function - M.ACTUATOR_OUTPUT_FUNCTION_SERVO1 < SERVO_COUNT
    if function is None or not (motor or servo):
        return M.MAV_RESULT_UNSUPPORTED, (f"Actuator test: param5 (function) {p[4]:g} is no motor 1..{ROTOR_COUNT} or "
                                          f"servo 1..{SERVO_COUNT} output here")  # fmt: skip
    if math.isinf(p[0]) or not math.isfinite(p[1]):
        return M.MAV_RESULT_DENIED, "Actuator test denied: param1 (value) infinite or param2 (time-out) not finite"
    index = function - (M.ACTUATOR_OUTPUT_FUNCTION_MOTOR1 if motor else M.ACTUATOR_OUTPUT_FUNCTION_SERVO1)
    return OutputTest(motor, index, p[0] if p[1] > 0.0 else None, p[1])
