"""The MPC's horizon: the stage grid, the warm start moved one tick along it, the set-point laid along it, and the
choice of horizon (docs/design/alternatives.md, the long horizon)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aircraft.codegen import BufferedFunction
from autopilot.control.attitude import DEFAULT_GAINS
from autopilot.controllers import mpc_horizon
from autopilot.mpc.horizon import LONG, PAPER, StageGrid, extrapolate_setpoint
from autopilot.mpc.model import CHI, NU, NX, angle_chain, step_parameters, yaw_references
from autopilot.mpc.rti import RtiSolver, planned_force_function


def test_the_long_grid_sees_two_seconds_with_the_papers_number_of_stages():
    assert PAPER.grid.stages == LONG.grid.stages == 25
    assert PAPER.grid.span_s == pytest.approx(0.25)
    assert LONG.grid.span_s >= 2.0
    assert LONG.grid.node_at(0.03) == 3  # the servo lead falls on a node of the fine part


def test_one_tick_later_is_one_stage_on_the_papers_grid():
    interval, fraction = PAPER.grid.shift_sources()
    assert list(interval) == [*range(1, 26), 25]
    assert list(fraction) == [0.0] * 25 + [1.0]  # the last node: one tick past the plan's end


def test_one_tick_later_falls_inside_the_long_stages():
    interval, fraction = StageGrid((1, 1, 4, 4)).shift_sources()
    assert list(interval) == [1, 2, 2, 3, 4]
    assert list(fraction) == [0.0, 0.0, 0.25, 0.25, 1.0]


@pytest.mark.parametrize("ticks", [(), (1, 0), (2, -1)])
def test_a_grid_without_stages_of_at_least_one_tick_is_refused(ticks):
    with pytest.raises(ValueError):
        StageGrid(ticks)


def test_the_shift_on_the_papers_grid_moves_the_plan_by_one_stage(airframe):
    solver = RtiSolver(airframe, StageGrid.uniform(5))
    solver.w[:] = np.arange(solver.n_w, dtype=float) / solver.n_w
    old_states, old_inputs = solver.states(), solver.inputs()
    solver.shift()
    assert np.array_equal(solver.states()[:5], old_states[1:])
    assert np.array_equal(solver.inputs()[:4], old_inputs[1:])
    assert np.array_equal(solver.inputs()[4], old_inputs[4])  # the last input repeated
    # the new terminal state: the model's step over one tick from the old one, bit for bit as CasADi evaluates it
    tick = step_parameters(0.01, True, DEFAULT_GAINS.vector())
    expected = np.asarray(solver.step_function(old_states[5], old_inputs[4], tick)).ravel()
    assert np.array_equal(solver.states()[5], expected)


def test_a_buffered_function_gives_the_functions_values(airframe):
    force = planned_force_function(airframe)
    buffered = BufferedFunction(force)
    rng = np.random.default_rng(3)
    for _ in range(3):
        x, u = rng.normal(size=NX), np.abs(rng.normal(size=NU))
        assert np.array_equal(buffered(x, u)[0], np.asarray(force(x, u)).ravel())
    with pytest.raises(ValueError):
        buffered(np.zeros(NX))  # one argument short


def test_the_shift_on_a_long_stage_interpolates_the_states(airframe):
    solver = RtiSolver(airframe, StageGrid((1, 4)))
    stride = NX + NU
    solver.w[:] = 0.0
    solver.w[0:NX] = 1.0  # node 0 (t = 0)
    solver.w[stride : stride + NX] = 2.0  # node 1 (t = 1 tick)
    solver.w[2 * stride :] = 6.0  # node 2 (t = 5 ticks)
    solver.w[stride + NX : 2 * stride] = 0.5  # the input of the long stage
    solver.shift()
    states = solver.states()
    assert np.allclose(states[0], 2.0)  # t = 1 tick: node 1
    assert np.allclose(states[1], 3.0)  # t = 2 ticks: a quarter into the long stage
    assert np.allclose(solver.inputs()[1], 0.5)  # the input in force there


def test_a_straight_extrapolation_is_the_papers_line():
    times = LONG.grid.times_s
    v_sp, rate = np.array([20.0, 0.0, 0.0]), np.array([-2.0, 0.0, 0.0])
    velocities, rates = extrapolate_setpoint(v_sp, rate, times, turning=True)
    assert np.allclose(velocities[0], 20.0 - 2.0 * times)
    assert np.allclose(rates[0], -2.0) and np.allclose(velocities[1:], 0.0)


def test_a_turning_set_point_stays_on_its_circle():
    speed, radius = 26.0, 250.0
    v_sp = np.array([speed, 0.0, 0.0])
    rate = np.array([0.0, speed**2 / radius, 0.0])  # turning right (east) at the circle's rate
    times = LONG.grid.times_s
    velocities, rates = extrapolate_setpoint(v_sp, rate, times, turning=True)
    assert np.allclose(np.hypot(velocities[0], velocities[1]), speed)
    assert np.allclose(np.arctan2(velocities[1], velocities[0]), speed / radius * times)
    assert np.allclose(np.hypot(rates[0], rates[1]), speed**2 / radius)
    straight, _ = extrapolate_setpoint(v_sp, rate, times, turning=False)
    assert np.hypot(straight[0, -1], straight[1, -1]) > speed + 0.5  # the line leaves the circle


def test_the_horizon_comes_from_the_option_else_the_parameter():
    assert mpc_horizon(None, 0) is PAPER and mpc_horizon(None, 1) is LONG
    assert mpc_horizon("paper", 1) is PAPER and mpc_horizon("long", 0) is LONG
    with pytest.raises(ValueError, match="horizon"):
        mpc_horizon("forever", 0)
    with pytest.raises(ValueError, match="VT_MPC_HRZN"):
        mpc_horizon(None, 2)


def test_long_stages_hold_the_delayed_rate_in_continuous_form(airframe):
    """On a stage many ticks long the previous stage's rate is not held (it would be that many ticks old): the
    step does not depend on Psi_dot_prev there, and does on a one-tick stage."""
    step = RtiSolver(airframe, LONG.grid).step_function
    x, u = np.zeros(NX), np.zeros(NU)
    x[CHI] = math.radians(10)
    u[4:8] = airframe.hover_thrust_per_rotor
    moved = x.copy()
    moved[13:16] = 0.5  # Psi_dot_prev
    gains = DEFAULT_GAINS.vector()
    long_stage, tick = step_parameters(0.13, False, gains), step_parameters(0.01, True, gains)
    assert np.array_equal(np.asarray(step(x, u, long_stage)), np.asarray(step(moved, u, long_stage)))
    assert not np.array_equal(np.asarray(step(x, u, tick)), np.asarray(step(moved, u, tick)))


def _chained_one_by_one(start: float, angles: np.ndarray, valid: np.ndarray) -> list[float]:
    psi, chain = start, []
    for angle, ok in zip(angles, valid):
        if ok:
            psi = psi + math.atan2(math.sin(angle - psi), math.cos(angle - psi))
        chain.append(psi)
    return chain


@pytest.mark.parametrize("valid", [[True] * 6, [False] * 6, [False, True, False, False, True, True],
                                   [True, False, False, True, False, False]])  # fmt: skip
def test_the_angle_chain_unwraps_each_stage_to_within_pi_of_the_one_before(valid):
    angles = np.array([3.0, -3.0, 2.9, -2.0, 0.5, -3.1])  # courses across +-pi: the chain must not jump by 2 pi
    start = 7.0  # the yaw now, two turns and a bit: the chain continues from it
    chain = angle_chain(start, angles, np.array(valid))
    assert chain == pytest.approx(_chained_one_by_one(start, angles, np.array(valid)), abs=1e-12)
    assert np.all(np.abs(np.diff(np.concatenate(([start], chain)))) <= math.pi)


def test_yaw_references_follow_the_course_above_three_metres_per_second():
    v_sp = np.array([[-10.0, -10.0, 1.0, 2.0], [0.1, -0.1, 0.0, 2.0], [0.0, 0.0, 0.0, 0.0]])
    psi = yaw_references(v_sp, 3.0)
    assert psi[0] == pytest.approx(math.atan2(0.1, -10.0))  # within pi of the yaw now (3.0)
    assert psi[1] == pytest.approx(psi[0] + math.atan2(-0.1, -10.0) - math.atan2(0.1, -10.0) + 2 * math.pi)
    assert psi[2] == psi[1] and psi[3] == psi[1]  # 1 m/s and 2.8 m/s: no course, the stage before's kept
