"""The MPC solving one tick ahead in its own process (autopilot/mpc_overlap.py, VT_MPC_OVERLAP): the maths of the
prediction, the failure state handed to the solving process, the process's end, and lockstep flights through the
real processes that repeat bit for bit."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

from aircraft.actuators import ALLOCATED_ROTORS
from aircraft.failures import FailureType, FailureUnit, parse_failure
from autopilot.actuator_health import ActuatorHealth, ServoEstimate
from autopilot.allocation import ControlAllocator
from autopilot.controllers import build_flight_controller
from autopilot.flight_controller import MPC, VELOCITY_PERIOD_USEC
from autopilot.mpc_controller import euler_rates
from autopilot.mpc_model import THRUST
from autopilot.mpc_overlap import HealthSnapshot, OverlappedMpc, body_rates
from autopilot.vehicle_state import VehicleState
from tiltrotor_sitl import Vehicle
from transport.flight_log import VN, VN_SP, read_flight_log


@pytest.mark.parametrize("euler", [(0.0, 0.0, 0.0), (0.3, -0.4, 2.5), (-1.0, 1.2, -3.0)])
def test_body_rates_invert_the_euler_rates(euler):
    euler, omega = np.array(euler), np.array([0.4, -0.7, 1.1])
    assert np.allclose(body_rates(euler, euler_rates(euler, omega)), omega, atol=1e-12)


def test_the_health_snapshot_carries_every_failure_kind(airframe):
    allocator, servos = ControlAllocator(airframe), ServoEstimate(airframe)
    servos.tilt[:] = [0.1, 0.2, 0.3, 0.4]
    health = ActuatorHealth(airframe, allocator, servos)
    for unit, kind, instance, value in ((FailureUnit.MOTOR, FailureType.OFF, 1, 0.0),
                                        (FailureUnit.MOTOR, FailureType.WRONG, 3, 0.3),
                                        (FailureUnit.SERVO, FailureType.STUCK, 2, math.nan),
                                        (FailureUnit.SERVO, FailureType.WRONG, 4, 0.5)):  # fmt: skip
        health.apply(parse_failure(unit, kind, instance, value))
    copy_allocator, copy_servos = ControlAllocator(airframe), ServoEstimate(airframe)
    HealthSnapshot.of(allocator, servos).apply_to(copy_allocator, copy_servos)
    for name in ("effectiveness", "lower", "upper"):
        assert np.array_equal(getattr(copy_allocator, name), getattr(allocator, name)), name
    assert np.array_equal(copy_servos.stuck, servos.stuck, equal_nan=True) and copy_servos.stuck[1] == 0.2
    assert np.array_equal(copy_servos.rate_scale, servos.rate_scale)


def hover(time_usec: int) -> VehicleState:
    return VehicleState(time_usec=time_usec, valid=True)


def test_a_motor_failure_reaches_the_solving_process_and_the_process_ends(airframe):
    controller = build_flight_controller(airframe, MPC, mpc_overlap=True)
    mpc = controller.mpc
    assert isinstance(mpc, OverlappedMpc)
    for tick in range(3):
        controller.step(hover(tick * VELOCITY_PERIOD_USEC))
    assert controller.last_mpc_solution.u[0][THRUST][0] > 1.0  # rotor 1 lifts its share
    controller.apply_failure(parse_failure(FailureUnit.MOTOR, FailureType.OFF, 1, 0.0))
    thrusts = []
    for tick in range(3, 8):
        controller.step(hover(tick * VELOCITY_PERIOD_USEC))
        thrusts.append(controller.last_mpc_solution.u[0][THRUST][0])
    # The solve in flight when the failure became known was started before it: one tick later the plan knows.
    assert thrusts[0] > 1.0 and max(abs(t) for t in thrusts[1:]) < 0.05
    assert controller.allocator.upper[ALLOCATED_ROTORS][0] == 0.0
    assert controller.controller_statistics()["solves_failed"] == 0
    pid = mpc.pid
    mpc.close()
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)


def fly_accel(tmp_path: Path, name: str, overlap: int, duration_s: float = 3.0) -> tuple[bytes, dict]:
    """The MPC flying 3 s of the acceleration profile in lockstep; the 100 Hz log's bytes and the summary."""
    log = tmp_path / f"{name}.csv"
    with Vehicle(controller="mpc", spawn_alt=100.0, speed=None, truth=False, summary=True, duration_s=duration_s,
                 wait_ready=False, params={"VT_MPC_OVERLAP": overlap},
                 autopilot_args=("--profile", "accel", "--log", str(log), "--quiet")) as vehicle:  # fmt: skip
        vehicle.wait_finished(timeout_s=300.0)
        summary = vehicle.summary("vtol-autopilot")
    return log.read_bytes(), summary


def test_overlapped_lockstep_flights_repeat_bit_for_bit_and_differ_from_the_synchronous_one(tmp_path):
    first, summary = fly_accel(tmp_path, "a", 1)
    second, _ = fly_accel(tmp_path, "b", 1)
    synchronous, synchronous_summary = fly_accel(tmp_path, "sync", 0)
    assert first == second
    assert first != synchronous  # the one-tick delay is real
    for flight in (summary, synchronous_summary):
        assert flight["controller"]["solves_failed"] == 0 and not flight["controller"]["fell_back_to_pid"]
    # Both track the ramp alike: the delay is compensated (0.23 m/s RMS in-process over 6 s for either).
    errors = []
    for name in ("a", "sync"):
        log = read_flight_log(tmp_path / f"{name}.csv").columns
        errors.append(float(np.sqrt(np.mean((log[VN] - log[VN_SP]) ** 2))))
    assert errors[0] < 0.5 and abs(errors[0] - errors[1]) < 0.05 * errors[1]
