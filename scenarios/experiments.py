"""The paper's five experiments as data: profile, duration, failure and its trigger, what the paper saw.

A failure is injected by the ground station (MAV_CMD_INJECT_FAILURE) the first time its trigger condition is
seen in the MAVLink telemetry, as a tester at a ground station would.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from aircraft.failures import Failure, FailureType, FailureUnit
from scenarios.profiles import CIRCLE_RADIUS, CIRCLE_SPEED, PROFILES, circle_start

GRAVITY = 9.80665  # m/s^2, for the bank angle a coordinated turn needs


@dataclass(frozen=True)
class Circle:
    """The intended circle of a circle scenario: it starts at `start_s`, flown clockwise seen from above
    (north, then east) at the start heading north, with radius `radius`."""

    start_s: float
    radius: float


@dataclass(frozen=True)
class Telemetry:
    """What the trigger conditions look at: the latest MAVLink telemetry (angles in degrees)."""

    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    yaw_deg: float = 0.0
    yaw_unwrapped_deg: float = 0.0  # the yaw plus 360 deg for each turn to the right since the start (- to the left)
    tilt_cmd_deg: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)  # from SERVO_OUTPUT_RAW
    ground_speed: float = 0.0  # m/s, horizontal, from LOCAL_POSITION_NED


@dataclass(frozen=True)
class TriggeredFailure:
    """A MAV_CMD_INJECT_FAILURE (`injection`), sent when `condition` first holds."""

    injection: Failure
    condition: Callable[[Telemetry], bool]
    trigger: str  # the condition in words


@dataclass(frozen=True)
class Scenario:
    name: str
    profile: Callable[[float], np.ndarray]
    duration_s: float
    summary: str
    paper: str  # the paper's result to compare with
    circle: Circle | None = None
    failure: TriggeredFailure | None = None


def servo_reaches(servo: int, angle_deg: float) -> Callable[[Telemetry], bool]:
    return lambda telemetry: telemetry.tilt_cmd_deg[servo - 1] >= angle_deg


def ground_speed_reaches(speed: float) -> Callable[[Telemetry], bool]:
    return lambda telemetry: telemetry.ground_speed >= speed


def yaw_reaches(angle_deg: float) -> Callable[[Telemetry], bool]:
    """The yaw has turned right to `angle_deg` (0 ... 360) from north: the unwrapped yaw, so 240 deg is reached
    two thirds of the way round a right-hand circle, not at once (-120 deg wrapped)."""
    return lambda telemetry: telemetry.yaw_unwrapped_deg >= angle_deg


CIRCLE = Circle(circle_start(0.0), CIRCLE_RADIUS)
BANK_THEORY_DEG = math.degrees(math.atan(CIRCLE_SPEED**2 / (GRAVITY * CIRCLE_RADIUS)))
SERVO_1_STUCK_AT_60 = TriggeredFailure(Failure(FailureUnit.SERVO, FailureType.STUCK, 1, 60.0), servo_reaches(1, 60.0),
                                       "servo 1 command reaches 60 deg")  # fmt: skip
ROTOR_1_OFF_AT_YAW_90 = TriggeredFailure(Failure(FailureUnit.MOTOR, FailureType.OFF, 1), yaw_reaches(90.0),
                                         "yaw reaches 90 deg")  # fmt: skip

SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario("accel", *PROFILES["accel"], "v_sp = (min(2t, 27.74), 0, 0): hover to cruise",
                 "reaches 27.74 m/s in ~14 s; near-zero v_z; max pitch -18 deg (MPC) vs -32 deg (PID); "
                 "tilt rises smoothly 0 -> 90 deg (PID in steps)"),
        Scenario("accel-decel", *PROFILES["accel-decel"], "v_x to 24 m/s at 2 m/s^2, then back to 0 from t = 15 s",
                 "smooth both ways; while braking the MPC tilts the rotors back to about -7 deg near t = 22 s, "
                 "then forward to hover"),
        Scenario("circle", *PROFILES["circle"], "2 m/s^2 to 26 m/s, then one turn of a 250 m circle",
                 f"steady bank (paper 20 deg; v^2/(gR) gives {BANK_THEORY_DEG:.1f} deg), pitch up, yaw rising "
                 "steadily, on the 250 m circle", circle=CIRCLE),
        Scenario("servo-failure", *PROFILES["accel"], "accel with servo 1 stuck at 60 deg once it reaches 60 deg",
                 "keeps tracking v_x; brief roll/yaw deviation, recovers", failure=SERVO_1_STUCK_AT_60),
        Scenario("motor-failure", *PROFILES["circle"], "circle with rotor 1 off once the yaw reaches 90 deg",
                 "the other rotors (rotor 2 most) speed up; small roll/yaw error; stays on the circle",
                 circle=CIRCLE, failure=ROTOR_1_OFF_AT_YAW_90),
    )
}  # fmt: skip
