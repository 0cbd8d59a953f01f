"""Every velocity controller keeps the VelocityController contract (autopilot/control/velocity_controller.py), checked
through the real classes as autopilot.controllers builds them: finite commands for a range of states and
set-points, attitude and tilt set-points within the controller's limits, a phase name, the same commands for the
same inputs, the caller's arrays left alone."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aircraft.airframe import Airframe, load_airframe
from aircraft.failures import Failure, FailureType, FailureUnit
from aircraft.frames import quaternion_from_euler
from autopilot.control.flight_controller import VELOCITY_PERIOD_USEC
from autopilot.control.pid_baseline import PidVelocityController
from autopilot.control.velocity_command import VelocityCommand
from autopilot.control.velocity_controller import VelocityController
from autopilot.controllers import KINDS, build_flight_controller
from autopilot.mpc.controller import MpcVelocityController
from autopilot.mpc.model import THRUST
from autopilot.mpc.overlap import OverlappedMpc
from autopilot.mpc.rti import MpcSolution
from autopilot.topics.controller_kind import MPC
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawReference

TICKS = 25  # 0.25 s at 100 Hz per case
MPC_OVERLAPPED = "mpc-overlapped"  # the MPC solving one tick ahead on its worker thread (VT_MPC_OVERLAP = 1)
VARIANTS = (*KINDS, MPC_OVERLAPPED)
TOLERANCE = 1e-6  # rad: the MPC meets its bounds to the QP's tolerance
Jams = tuple[float | None, float | None, float | None, float | None]  # per tilt servo: its jam (deg), None if free


@pytest.fixture(scope="module")
def airframe() -> Airframe:
    return load_airframe()


def state_at(time_usec: int, velocity, euler_deg, rates=(0.0, 0.0, 0.0)) -> VehicleState:
    euler = np.radians(euler_deg)
    state = VehicleState(time_usec=time_usec, valid=True)
    state.velocity_ned = np.array(velocity, dtype=float)
    state.euler = euler
    state.quaternion = np.asarray(quaternion_from_euler(*euler), dtype=float).ravel()
    state.body_rates = np.array(rates, dtype=float)
    state.airspeed = float(np.linalg.norm(state.velocity_ned))
    return state


# (state velocity NED m/s, Euler deg, body rates rad/s, tilts deg, set-point NED m/s)
CASES = {
    "hover, hold": ((0, 0, 0), (0, 0, 0), (0, 0, 0), 0, (0, 0, 0)),
    "hover, climb and slide": ((0, 0, 0), (0, 0, 30), (0, 0, 0), 0, (0, 3, -2)),
    "hover, cruise asked": ((0, 0, 0), (0, 0, 0), (0, 0, 0), 0, (27.74, 0, 0)),
    "transition, brake": ((15, 0, 0), (0, 5, 0), (0, 0.1, 0), 45, (0, 0, 0)),
    "cruise, hold": ((26, 0, 0), (0, 2, 0), (0, 0, 0), 90, (26, 0, 0)),
    "cruise, turn and sink": ((25, 5, 1), (20, 3, 11), (0.1, 0, 0.2), 85, (20, 15, 2)),
    "heading near 180": ((-10, 0.1, 0), (0, 0, 179.9), (0, 0, 0), 30, (-10, -0.5, 0)),
    "upset": ((3, -4, 3), (40, -30, -90), (1.0, -1.0, 0.5), 20, (0, 0, 0)),
}


def build(airframe: Airframe, variant: str, failure: Failure | None = None) -> VelocityController:
    """The velocity controller of a flight controller (told of `failure` when given)."""
    overlapped = variant == MPC_OVERLAPPED
    kind = MPC if overlapped else variant
    flight = build_flight_controller(airframe, kind, mpc_overlap=overlapped)
    if failure is not None:
        flight.apply_failure(failure)
    controller = flight.velocity_controller
    expected = OverlappedMpc if overlapped else MpcVelocityController if kind == MPC else PidVelocityController
    assert isinstance(controller, expected)
    return controller


def attitude_limit(controller: VelocityController) -> float:
    """The largest roll or pitch set-point the controller may ask for (rad), from its own declared limits."""
    if isinstance(controller, (MpcVelocityController, OverlappedMpc)):
        return max(controller.limits.attitude_sp)
    p = controller.p
    return math.radians(max(p.mc_tilt_max_deg, p.fw_roll_max_deg, p.fw_pitch_max_deg))


def fly(controller: VelocityController, case: str, jammed: Jams | None = None) -> list[VelocityCommand]:
    """The case's commands; the tilts of `jammed` servos (deg, None: free) at their jam, where the servo estimate
    has them once they got there."""
    velocity, euler, rates, tilt_deg, v_sp = CASES[case]
    tilts = np.radians([tilt_deg if jam is None else jam for jam in (jammed or (None,) * 4)])
    setpoint = np.array(v_sp, dtype=float)
    commands = []
    for tick in range(TICKS):
        state = state_at(tick * VELOCITY_PERIOD_USEC, velocity, euler, rates)
        tilts_before, setpoint_before = tilts.copy(), setpoint.copy()
        commands.append(controller.update(state, setpoint, tilts))
        assert np.array_equal(tilts, tilts_before) and np.array_equal(setpoint, setpoint_before)  # inputs untouched
    return commands


def arrays(command: VelocityCommand) -> tuple[np.ndarray, ...]:
    return command.euler_sp, command.tilt_sp, command.force_sp_body, command.force_weights


def assert_keeps_the_contract(command: VelocityCommand, airframe: Airframe, limit: float) -> None:
    """Finite set-points of the right shapes, attitude and tilts within the limits, weights in 0..1, a phase name."""
    for values in arrays(command):
        assert values.shape in ((3,), (4,)) and np.all(np.isfinite(values))
    assert np.all(np.abs(command.euler_sp[0:2]) <= limit + TOLERANCE)
    assert np.all(command.tilt_sp >= airframe.tilt_min - TOLERANCE)
    assert np.all(command.tilt_sp <= airframe.tilt_max + TOLERANCE)
    assert np.all((command.force_weights >= 0.0) & (command.force_weights <= 1.0))
    assert isinstance(command.mode, str) and command.mode


def assert_the_same(first: list[VelocityCommand], second: list[VelocityCommand]) -> None:
    for a, b in zip(first, second):
        assert a.mode == b.mode and a.yaw_by_tilt == b.yaw_by_tilt
        for values_a, values_b in zip(arrays(a), arrays(b)):
            assert np.array_equal(values_a, values_b)


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("kind", VARIANTS)
def test_commands_are_finite_and_within_the_limits(airframe, kind, case):
    controller = build(airframe, kind)
    limit = attitude_limit(controller)
    switches = controller.mode_switches
    for command in fly(controller, case):
        assert_keeps_the_contract(command, airframe, limit)
        assert isinstance(controller.mode_switches, int) and controller.mode_switches >= switches
        switches = controller.mode_switches


@pytest.mark.parametrize("kind", VARIANTS)
def test_the_same_inputs_give_the_same_commands(airframe, kind):
    for case in ("hover, cruise asked", "cruise, turn and sink"):
        assert_the_same(fly(build(airframe, kind), case), fly(build(airframe, kind), case))


@pytest.mark.parametrize("kind", VARIANTS)
def test_a_controller_starts_without_mode_switches(airframe, kind):
    assert build(airframe, kind).mode_switches == 0


@pytest.mark.parametrize("kind", VARIANTS)
def test_a_yaw_reference_turns_the_yaw_set_point_towards_it(airframe, kind):
    """The contract's yaw input: the attitude set-point's yaw moves towards the reference (here 60 deg left of the
    nose, turning left at 0.3 rad/s), within the limits, and a hover without one keeps the nose."""
    controller = build(airframe, kind)
    reference = YawReference(math.radians(-60.0), -0.3)
    for tick in range(TICKS):
        command = controller.update(state_at(tick * VELOCITY_PERIOD_USEC, (0, 0, 0), (0, 0, 0)), np.zeros(3),
                                    np.zeros(4), reference)  # fmt: skip
        assert np.all(np.isfinite(command.euler_sp)) and np.all(np.abs(command.euler_sp[0:2]) <= attitude_limit(
            controller) + TOLERANCE)  # fmt: skip
        assert command.euler_sp[2] < math.radians(-5.0)
    held = fly(build(airframe, kind), "hover, hold")[-1]
    assert abs(held.euler_sp[2]) < math.radians(1.0)


@pytest.mark.parametrize("kind", VARIANTS)
def test_a_hover_holds_its_heading_when_the_nose_is_pushed_off_it(airframe, kind):
    """Without a course or a yaw reference the heading the set-point lost its course at is held: a yaw pushed 20 deg
    off it (a gust on a crosswind) gets a yaw set-point back towards it, not the new yaw kept."""
    controller = build(airframe, kind)
    for tick in range(TICKS):
        yaw_deg = 0.0 if tick < 10 else 20.0
        command = controller.update(state_at(tick * VELOCITY_PERIOD_USEC, (0, 0, 0), (0, 0, yaw_deg)), np.zeros(3),
                                    np.zeros(4))  # fmt: skip
    assert command.euler_sp[2] < math.radians(15.0)


# ---- the same contract with a failure known (MAV_CMD_INJECT_FAILURE accepted, or found by the failure detector) ----

# failure -> (what the controllers are told, the tilts (deg) the servo estimate gives them)
FAILURES = {
    "rotor 1 off": (Failure(FailureUnit.MOTOR, FailureType.OFF, 1), None),
    "rotor 3 stuck at 40 %": (Failure(FailureUnit.MOTOR, FailureType.STUCK, 3, 0.4), None),
    "tilt servo 1 jammed at 60 deg": (Failure(FailureUnit.SERVO, FailureType.STUCK, 1, 60.0), (60.0, None, None, None)),
    "tilt servo 2 jammed at 0 deg": (Failure(FailureUnit.SERVO, FailureType.STUCK, 2, 0.0), (None, 0.0, None, None)),
    "tilt servo 4 at half its rate": (Failure(FailureUnit.SERVO, FailureType.WRONG, 4, 0.5), None),
    "elevon 1 stuck at 10 deg": (Failure(FailureUnit.SERVO, FailureType.STUCK, 5, 10.0), None),
}
FAILURE_CASES = ("hover, hold", "hover, cruise asked", "transition, brake", "cruise, turn and sink")


@pytest.mark.parametrize("failure", sorted(FAILURES))
@pytest.mark.parametrize("case", FAILURE_CASES)
@pytest.mark.parametrize("kind", VARIANTS)
def test_with_a_failure_known_the_commands_are_finite_within_the_limits_and_repeat(airframe, kind, case, failure):
    told, jammed = FAILURES[failure]
    controller = build(airframe, kind, told)
    limit = attitude_limit(controller)
    commands = fly(controller, case, jammed)
    for command in commands:
        assert_keeps_the_contract(command, airframe, limit)
    assert_the_same(commands, fly(build(airframe, kind, told), case, jammed))


@pytest.mark.parametrize("case", FAILURE_CASES)
@pytest.mark.parametrize("kind", (MPC, MPC_OVERLAPPED))
def test_the_mpc_plans_a_jammed_servo_where_it_jammed_and_no_thrust_on_a_dead_rotor(airframe, kind, case):
    """The MPC's own side of a failure (docs/mpc.md, failures): the jammed servo's tilt set-point is its jam, and the
    plan gives a rotor that is off no thrust."""
    told, jammed = FAILURES["tilt servo 1 jammed at 60 deg"]
    for command in fly(build(airframe, kind, told), case, jammed):
        assert command.tilt_sp[0] == pytest.approx(math.radians(60.0), abs=TOLERANCE)
    controller = build(airframe, kind, FAILURES["rotor 1 off"][0])
    fly(controller, case)
    solution = controller.last_solution
    assert isinstance(solution, MpcSolution) and solution.ok
    assert np.abs(solution.u[:, THRUST][:, 0]).max() < 1e-6
