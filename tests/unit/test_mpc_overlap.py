"""The MPC solving one tick ahead on its solver's worker thread (autopilot/mpc/overlap.py, VT_MPC_OVERLAP): the
maths of the prediction, the C back-end's steps on the worker thread equal to the same steps taken here, a failure
reaching the next solve, and lockstep flights through the real processes that repeat bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from aircraft.actuators import ALLOCATED_ROTORS
from aircraft.failures import FailureType, FailureUnit, parse_failure
from autopilot.control.attitude import euler_rates
from autopilot.control.flight_controller import VELOCITY_PERIOD_USEC
from autopilot.controllers import build_flight_controller
from autopilot.mpc.horizon import HORIZONS
from autopilot.mpc.model import P_SOLVER, THRUST
from autopilot.mpc.overlap import OverlappedMpc, body_rates
from autopilot.topics.controller_kind import MPC
from autopilot.topics.vehicle_state import VehicleState


@pytest.mark.parametrize("euler", [(0.0, 0.0, 0.0), (0.3, -0.4, 2.5), (-1.0, 1.2, -3.0)])
def test_body_rates_invert_the_euler_rates(euler):
    euler, omega = np.array(euler), np.array([0.4, -0.7, 1.1])
    assert np.allclose(body_rates(euler, euler_rates(euler, omega)), omega, atol=1e-12)


def test_the_worker_threads_steps_are_the_steps_taken_one_by_one(airframe):
    """RtiSolver.start/finish (the C worker thread) and solve (the same steps in C, here) give the same plan, bit for
    bit, as the QPs solved one at a time with each step added in numpy: on the long horizon's two Gauss-Newton steps
    a tick, over ticks of a hover spawn with a velocity step."""
    horizon = HORIZONS["long"]
    mpcs = [build_flight_controller(airframe, MPC, mpc_horizon=horizon).mpc for _ in range(3)]
    for mpc in mpcs:
        assert mpc.solver.fast is not None
    v_sp = np.array([3.0, 1.0, -0.5])
    tilts = np.zeros(4)
    for tick in range(6):
        state = hover(tick * VELOCITY_PERIOD_USEC)
        threaded, here, by_hand = mpcs
        threaded.start(state, v_sp, tilts)
        a = threaded.finish()
        b = here.update(state, v_sp, tilts)
        x0 = by_hand._prepare(state, v_sp, tilts, None)
        solver = by_hand.solver
        solver.params[:] = by_hand.params
        solver.params[P_SOLVER] = solver.solver_rows
        for _ in range(solver.gauss_newton_steps):
            step = solver.fast.solve(solver.w, solver.params, x0, solver.lbw, solver.ubw, solver.levenberg)
            assert step.ok and np.all(np.isfinite(solver.fast.dw))
            solver.w += solver.fast.dw
        assert np.array_equal(threaded.solver.w, here.solver.w) and np.array_equal(here.solver.w, solver.w), tick
        assert np.array_equal(a.euler_sp, b.euler_sp) and np.array_equal(a.force_sp_body, b.force_sp_body)
        assert threaded.last_solution.iterations == here.last_solution.iterations >= 2


def hover(time_usec: int) -> VehicleState:
    return VehicleState(time_usec=time_usec, valid=True)


def test_a_motor_failure_reaches_the_next_solve(airframe):
    controller = build_flight_controller(airframe, MPC, mpc_overlap=True)
    mpc = controller.mpc
    assert isinstance(mpc, OverlappedMpc)
    for tick in range(3):
        controller.step(hover(tick * VELOCITY_PERIOD_USEC))
    assert mpc.last_solution.u[0][THRUST][0] > 1.0  # rotor 1 lifts its share
    controller.apply_failure(parse_failure(FailureUnit.MOTOR, FailureType.OFF, 1, 0.0))
    thrusts = []
    for tick in range(3, 8):
        controller.step(hover(tick * VELOCITY_PERIOD_USEC))
        thrusts.append(mpc.last_solution.u[0][THRUST][0])
    # The solve in flight when the failure became known was started before it: one tick later the plan knows.
    assert thrusts[0] > 1.0 and max(abs(t) for t in thrusts[1:]) < 0.05
    assert controller.allocator.upper[ALLOCATED_ROTORS][0] == 0.0
    assert controller.controller_statistics()["solves_failed"] == 0
