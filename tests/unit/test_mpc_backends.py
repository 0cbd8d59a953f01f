"""The MPC's two QP back-ends: HPIPM through its OCP-QP C interface (default) and CasADi's `conic` (fallback)."""

from __future__ import annotations

import gc
import math
import os
import time
import weakref

import numpy as np
import pytest

from autopilot.mpc.horizon import StageGrid
from autopilot.mpc.model import CHI, NP, NX, P_FREE_TILT
from autopilot.mpc.rti import QpBackend, RtiSolver


def problem(horizon: int) -> tuple[np.ndarray, np.ndarray]:
    x0 = np.zeros(NX)
    x0[0] = 6.0
    x0[CHI] = math.radians(30)
    params = np.zeros((NP, horizon + 1))
    params[0, :] = 9.0
    params[P_FREE_TILT, :] = 1.0
    return x0, params


def iterate(solver: RtiSolver, steps: int) -> list:
    x0, params = problem(solver.horizon)
    solver.set_actuator_limits(np.full(4, 23.0), np.full(4, np.nan))
    solver.initialise(x0, solver.airframe.hover_thrust_per_rotor)
    solver.levenberg = 0.1
    return [solver.solve(x0, params) for _ in range(steps)]


def test_both_back_ends_take_the_same_step(airframe):
    fast = RtiSolver(airframe, qp_tolerance=1e-8)
    slow = RtiSolver(airframe, qp_tolerance=1e-8, backend=QpBackend.CASADI_CONIC)
    assert (fast.backend, slow.backend) == (QpBackend.HPIPM_C, QpBackend.CASADI_CONIC)
    (a,), (b,) = iterate(fast, 1), iterate(slow, 1)
    assert a.ok and b.ok
    assert a.cost == pytest.approx(b.cost, rel=1e-12)  # the same QP data at the same guess
    # Measured: inputs 5.2e-5 apart (a thrust, in N: its cost weight is small, so HPIPM's tolerance allows that
    # much), states 2.6e-7.
    assert np.abs(a.u - b.u).max() < 2e-4
    assert np.abs(a.x - b.x).max() < 2e-6


def test_the_c_back_end_is_deterministic(airframe):
    first = iterate(RtiSolver(airframe), 4)
    second = iterate(RtiSolver(airframe), 4)
    for a, b in zip(first, second):
        assert np.array_equal(a.u, b.u) and np.array_equal(a.x, b.x)


@pytest.mark.parametrize("backend", [QpBackend.HPIPM_C, QpBackend.CASADI_CONIC])
def test_start_and_finish_give_what_solve_gives_one_solve_at_a_time(airframe, backend):
    """RtiSolver.start/finish (the C back-end's worker thread; without it, solved at start) equal solve, and a solve
    is started and finished once at a time."""
    grid = StageGrid.uniform(5)
    here, started = (RtiSolver(airframe, grid, backend=backend, gauss_newton_steps=2) for _ in range(2))
    x0, params = problem(grid.stages)
    for solver in (here, started):
        solver.set_actuator_limits(np.full(4, 23.0), np.full(4, np.nan))
        solver.initialise(x0, airframe.hover_thrust_per_rotor)
        solver.levenberg = 0.1
    for _ in range(3):
        a = here.solve(x0, params)
        started.start(x0, params)
        with pytest.raises(RuntimeError, match="finish"):
            started.start(x0, params)
        b = started.finish()
        assert a.ok and b.ok and (a.status, a.iterations, a.cost) == (b.status, b.iterations, b.cost)
        assert np.array_equal(here.w, started.w) and np.array_equal(a.u, b.u)
    with pytest.raises(RuntimeError, match="no solve"):
        started.finish()


def os_threads() -> set[str]:
    """The ids of this process's threads, the C workers among them (Linux: /proc/self/task)."""
    return set(os.listdir("/proc/self/task"))


@pytest.mark.skipif(not os.path.isdir("/proc/self/task"), reason="counts the process's threads in /proc")
def test_a_solver_dropped_while_its_solve_runs_is_freed_after_it(airframe):
    """The C object's worker thread ends when the object is freed, after the solve it runs (no hang, no crash): the
    object goes, its thread goes, and the solve had ended when it went (its buffers hold the whole solve's result,
    the one the same solve here gives, and nothing writes them afterwards)."""
    steps = 100  # about 0.1 s of solving: dropped while it runs, without a doubt
    reference, solver = (RtiSolver(airframe, StageGrid.uniform(25), gauss_newton_steps=steps) for _ in range(2))
    x0, params = problem(25)
    for each in (reference, solver):
        each.set_actuator_limits(np.full(4, 23.0), np.full(4, np.nan))
        each.initialise(x0, airframe.hover_thrust_per_rotor)
        each.levenberg = 0.1
    expected = reference.solve(x0, params)
    assert solver.fast is not None and expected.ok
    guess, info = solver.fast._w, solver.fast._info  # the buffers its worker writes, kept here past the free
    threads = os_threads()
    solver.start(x0, params)
    worker = os_threads() - threads
    assert len(worker) == 1  # its worker thread, started with the first solve
    deadline = time.monotonic() + 30
    while info[1] == 0:  # the first QP's iterations: the worker has the solve and runs it
        assert time.monotonic() < deadline, "the worker never took the solve"
        time.sleep(0.0005)
    assert info[8] == 0  # still running: the total is written when the last step ends
    freed, fast_freed = weakref.ref(solver), weakref.ref(solver.fast)
    del solver, each  # (the loop above left `each` on it)
    gc.collect()
    assert freed() is None and fast_freed() is None
    assert not worker & os_threads()  # the worker thread has ended
    after_free = guess.copy(), info.copy()
    assert np.array_equal(guess, reference.w) and int(info[8]) == expected.iterations  # the whole solve's result
    time.sleep(0.05)
    assert np.array_equal(guess, after_free[0]) and np.array_equal(info, after_free[1])  # nothing writes them now
