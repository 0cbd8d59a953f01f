"""Control allocation (docs/autopilot.md; paper section "Control allocation"): body wrench set-point -> 8 actuators.

Actuators u = (u1..u4 rotor thrust fractions 0..1, aileron L, aileron R, elevator, rudder -1..1), the order of
aircraft.wrench.ALLOCATED_ACTUATORS. Tilts are not allocated: they are inputs (the velocity controller's).

The QP, its data and the optimality gap are CasADi functions of the shared model: autopilot/control/allocation_qp.py.

u = u_trim + du is clipped to [lb, ub] (the solver meets the box only to its tolerance) and the achieved wrench
W(u) is evaluated with the same model function. The QP is solved by proxsuite's dense solver with native box
constraints, kept alive between calls and warm started from its previous result (docs/design/solver.md), its
preconditioner updated at every call; each answer's optimality gap is checked, and a wrong one solved again by a
fresh solver (docs/autopilot.md).

Failures (docs/autopilot.md; sim_bridge/failures.py is the plant's side):

| plant failure (MAV_CMD_INJECT_FAILURE)     | allocator call                                             |
| rotor OFF                                  | set_failed(i): column zeroed, bounds [0, 0]                |
| rotor WRONG, thrust capped at f            | set_actuator_limit(i, 0, f)                                |
| surface STUCK / OFF at deflection d        | set_actuator_limit(i, d, d) (it still makes its moment)    |
| surface WRONG, effectiveness f             | set_effectiveness(i, f) (column scaled, command still +-1) |
| paper's "rudder 20 % effective" as bounds  | set_actuator_limit(7, -0.2, 0.2)                           |
| failure cleared                            | clear(i)                                                   |

Never NaN: a non-finite set-point or flight state, or a solver failure, returns the previous solution (clipped
to the current bounds) with `fallback=True` and a status saying why.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import proxsuite

from aircraft.airframe import Airframe
from aircraft.codegen import compiled
from aircraft.wrench import ALLOCATED_ACTUATORS
from autopilot.control.allocation_qp import N_ACTUATORS, N_WRENCH, build_allocation_functions

LOWER_NOMINAL = np.array([0.0, 0.0, 0.0, 0.0, -1.0, -1.0, -1.0, -1.0])
UPPER_NOMINAL = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
DEFAULT_LEAST_EFFORT = 1e-6  # eps relative to the largest diagonal entry of A^T Q A

STATUS_SOLVED = "solved"
STATUS_INVALID_INPUT = "invalid_input"  # non-finite set-point, tilts, airspeed or rates
STATUS_INVALID_MODEL = "invalid_model"  # non-finite A, W or solution although the inputs were finite (a bug)
STATUS_NOT_OPTIMAL = "not_optimal"  # the solver said solved, the optimality conditions say otherwise (twice)
# Largest optimality gap (actuator units, allocation_qp.py) accepted. Replaying a recorded flight's 4216 calls:
# correct answers stayed below 1e-7; the wrong "solved" answers of proxsuite#477 (rotors > 0.01 off) had 0.037
# to 0.54. The PWM on the wire resolves 1e-3.
OPTIMALITY_TOL = 1e-4

# proxsuite's result depends in its last bits on where its buffers happen to lie in memory (up to ~2e-11 here), so
# the same flight flown twice could differ, and a long flight amplifies that. A step rounded to 1e-9 (the PWM on
# the wire resolves 1e-3) makes the allocation a function of its inputs alone.
DU_DECIMALS = 9

_QP = proxsuite.proxqp
_SOLVED = _QP.QPSolverOutput.PROXQP_SOLVED
_STATUS_NAMES = {
    _QP.QPSolverOutput.PROXQP_SOLVED: STATUS_SOLVED,
    _QP.QPSolverOutput.PROXQP_MAX_ITER_REACHED: "max_iter_reached",
    _QP.QPSolverOutput.PROXQP_PRIMAL_INFEASIBLE: "primal_infeasible",
    _QP.QPSolverOutput.PROXQP_SOLVED_CLOSEST_PRIMAL_FEASIBLE: "solved_closest_primal_feasible",
    _QP.QPSolverOutput.PROXQP_DUAL_INFEASIBLE: "dual_infeasible",
    _QP.QPSolverOutput.PROXQP_NOT_RUN: "not_run",
}


@dataclass(frozen=True)
class AllocationResult:
    """One allocation. Arrays are the caller's own (copies); body FRD, N and N m."""

    u: np.ndarray  # (8) actuator commands, within the current bounds
    achieved: np.ndarray  # (6) W(u): the model's force and moment for u at this call's flight state
    residual: np.ndarray  # (6) W_sp - achieved (zeros where the set-point was not finite)
    status: str  # "solved", a proxsuite failure ("max_iter_reached", ...), "invalid_input" or "invalid_model"
    iterations: int  # proxsuite iterations (0 when the solver did not run)
    fallback: bool  # True: u is the previous solution (clipped to the bounds), because of `status`

    @property
    def ok(self) -> bool:
        return not self.fallback


class ControlAllocator:
    """Wrench set-point -> actuator commands, with failure-aware bounds (docs/autopilot.md); one per vehicle."""

    def __init__(
        self,
        airframe: Airframe,
        wrench_weights: Sequence[float] | None = None,
        least_effort: float = DEFAULT_LEAST_EFFORT,
        u_initial: Sequence[float] | None = None,
        compile_model: bool = True,
        eps_abs: float = 1e-7,
        max_iter: int = 200,
    ) -> None:
        """wrench_weights: Q = diag(w) on (Fx, Fy, Fz, L, M, N), default ones; least_effort: relative eps;
        u_initial: the first u_trim (default: rotors and surfaces at 0); compile_model: generated C via
        aircraft.codegen (else CasADi's VM); eps_abs, max_iter: proxsuite settings."""
        weights = np.ones(N_WRENCH) if wrench_weights is None else np.array(wrench_weights, dtype=float)
        if weights.shape != (N_WRENCH,) or not np.all(np.isfinite(weights)) or np.any(weights < 0):
            raise ValueError(f"wrench_weights must be 6 finite numbers >= 0, got {wrench_weights!r}")
        if not (math.isfinite(least_effort) and least_effort > 0):
            raise ValueError(f"least_effort must be > 0, got {least_effort!r}")
        self.airframe = airframe
        qp_function, wrench_function = build_allocation_functions(airframe)
        if compile_model:
            qp_function = compiled(qp_function, "vtol-autopilot")
            wrench_function = compiled(wrench_function, "vtol-autopilot")
        self._eps_abs, self._max_iter = eps_abs, max_iter

        # Persistent buffers: the CasADi buffer interface reads and writes them in place (no conversions).
        self._u = np.zeros(N_ACTUATORS)  # u_trim: the previous solution, then the new one
        self._effectiveness = np.ones(N_ACTUATORS)
        self._lower = LOWER_NOMINAL.copy()
        self._upper = UPPER_NOMINAL.copy()
        self._request = np.zeros(16)  # wrench_sp (6), tilts (4), v_air_body (3), rates_body (3)
        self._wrench_sp = self._request[0:6]
        self._state = self._request[6:16]
        self._tilts, self._v_air, self._rates = self._request[6:10], self._request[10:13], self._request[13:16]
        self._weights = weights
        self._least_effort = np.array([least_effort])
        self._hessian_flat = np.zeros(N_ACTUATORS * N_ACTUATORS)
        self._hessian = self._hessian_flat.reshape(N_ACTUATORS, N_ACTUATORS).T  # column-major view, as Eigen
        self._gradient = np.zeros(N_ACTUATORS)
        self._l_box = np.zeros(N_ACTUATORS)
        self._u_box = np.zeros(N_ACTUATORS)
        self._jacobian_flat = np.zeros(N_WRENCH * N_ACTUATORS)
        self._jacobian = self._jacobian_flat.reshape(N_ACTUATORS, N_WRENCH).T  # (6, 8) view of column-major data
        self._wrench_trim = np.zeros(N_WRENCH)
        self._achieved = np.zeros(N_WRENCH)
        self._residual = np.zeros(N_WRENCH)

        self._qp_buffer, self._evaluate_qp = qp_function.buffer()
        qp_args = (self._u, self._effectiveness, self._tilts, self._v_air, self._rates, self._wrench_sp,
                   self._weights, self._least_effort, self._lower, self._upper)  # fmt: skip
        for i, array in enumerate(qp_args):
            self._qp_buffer.set_arg(i, memoryview(array))
        qp_results = (self._hessian_flat, self._gradient, self._l_box, self._u_box, self._jacobian_flat,
                      self._wrench_trim)  # fmt: skip
        for i, array in enumerate(qp_results):
            self._qp_buffer.set_res(i, memoryview(array))
        self._optimality_gap = np.zeros(1)
        self._u_trim = np.zeros(N_ACTUATORS)  # u_trim kept while u is the candidate solution
        self._wrench_buffer, self._evaluate_wrench = wrench_function.buffer()
        for i, array in enumerate(qp_args):
            self._wrench_buffer.set_arg(i, memoryview(array))
        self._wrench_buffer.set_res(0, memoryview(self._achieved))
        self._wrench_buffer.set_res(1, memoryview(self._optimality_gap))

        self._qp: proxsuite.proxqp.dense.QP
        self.restarts = 0  # solver objects replaced because one answered "solved" with a wrong answer
        self.reset(u_initial)  # sets u_trim and creates the solver

    # ------------------------------------------------------------------ allocation

    def allocate(
        self,
        wrench_sp: Sequence[float] | np.ndarray,
        tilts: Sequence[float] | np.ndarray,
        v_air_body: Sequence[float] | np.ndarray,
        rates_body: Sequence[float] | np.ndarray,
    ) -> AllocationResult:
        """Actuators for the body wrench set-point W_sp = (force N, moment N m), gravity excluded, at the current
        tilts (rad), body airspeed (m/s) and body rates (rad/s). Raises ValueError only for wrong shapes."""
        self._wrench_sp[:] = wrench_sp
        self._tilts[:] = tilts
        self._v_air[:] = v_air_body
        self._rates[:] = rates_body
        request = self._request
        if not math.isfinite(request @ request):  # NaN or Inf anywhere (or absurd magnitudes > 1e150)
            return self._fallback(STATUS_INVALID_INPUT, 0)
        self._evaluate_qp()  # H, g, box, A, W(u_trim) in one call (generated C)
        if not math.isfinite(self._gradient @ self._gradient):
            return self._fallback(STATUS_INVALID_MODEL, 0)
        self._u_trim[:] = self._u
        status, iterations = self._solve()
        if status == STATUS_NOT_OPTIMAL:
            # proxsuite said "solved" and the optimality conditions say otherwise: a warm-started solver that
            # answered wrongly once may go on doing so, so a fresh one solves the same problem cold.
            self.restarts += 1
            self._u[:] = self._u_trim
            self._qp = self._new_solver()
            status, iterations = self._solve()
        if status != STATUS_SOLVED:
            self._u[:] = self._u_trim
            self._qp = self._new_solver()  # do not warm start from a failed run
            return self._fallback(status, iterations)
        np.subtract(self._wrench_sp, self._achieved, out=self._residual)
        return AllocationResult(
            self._u.copy(), self._achieved.copy(), self._residual.copy(), STATUS_SOLVED, iterations, False
        )

    def _solve(self) -> tuple[str, int]:
        """Solve the QP the buffers hold and, when solved, move u to the solution and evaluate W(u) and the
        optimality gap there: ("solved", iterations), or (why not, iterations) with u to be restored."""
        qp = self._qp
        # update_preconditioner=True: with the default False, proxsuite (0.8.0) rescales its box constraints'
        # multipliers by a factor that compounds on every update (Simple-Robotics/proxsuite#477); after some
        # thousand warm-started calls it answered "solved" with multipliers on bounds far from active, rotors
        # 0.37 from the optimum and tens of newtons unmet (a PID flight fell from 20 m).
        qp.update(self._hessian, self._gradient, None, None, None, None, None, self._l_box, self._u_box, True)
        qp.solve()
        results = qp.results
        iterations = int(results.info.iter)
        if results.info.status != _SOLVED:
            return _STATUS_NAMES.get(results.info.status, str(results.info.status)), iterations
        du = results.x
        if not math.isfinite(du @ du):  # defensive: proxsuite said solved but gave NaN
            return STATUS_INVALID_MODEL, iterations
        u = self._u
        u += du.round(DU_DECIMALS)  # u = u_trim + du: the paper's incremental form
        np.maximum(u, self._lower, out=u)
        np.minimum(u, self._upper, out=u)
        self._evaluate_wrench()  # achieved = W(u), same model, and the optimality gap at u
        if not self._optimality_gap[0] <= OPTIMALITY_TOL:
            return STATUS_NOT_OPTIMAL, iterations
        return STATUS_SOLVED, iterations

    def _fallback(self, status: str, iterations: int) -> AllocationResult:
        """Previous u, clipped to the current bounds; achieved and residual where they are defined."""
        u = self._u
        np.maximum(u, self._lower, out=u)
        np.minimum(u, self._upper, out=u)
        if np.all(np.isfinite(self._state)):
            self._evaluate_wrench()  # otherwise keep the last achieved wrench
        residual = np.nan_to_num(self._wrench_sp - self._achieved, nan=0.0, posinf=0.0, neginf=0.0)
        if not np.all(np.isfinite(self._achieved)):  # defensive: never hand out NaN
            self._achieved[:] = 0.0
            residual[:] = 0.0
        self._residual[:] = residual
        return AllocationResult(u.copy(), self._achieved.copy(), residual, status, iterations, True)

    def _new_solver(self) -> proxsuite.proxqp.dense.QP:
        """A persistent dense QP with native box constraints, warm started from its previous result.

        proxsuite 0.8.0 segfaults when a WARM_START_WITH_PREVIOUS_RESULT solve follows init + update before any
        solve has run (docs/design/solver.md), so it is solved once here on a dummy problem.
        """
        qp = _QP.dense.QP(N_ACTUATORS, 0, 0, True)
        qp.settings.eps_abs = self._eps_abs
        qp.settings.eps_rel = 0.0
        qp.settings.max_iter = self._max_iter
        qp.settings.verbose = False
        qp.settings.initial_guess = _QP.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
        identity = np.asfortranarray(np.eye(N_ACTUATORS))
        qp.init(identity, np.zeros(N_ACTUATORS), None, None, None, None, None, -UPPER_NOMINAL, UPPER_NOMINAL)
        qp.solve()
        return qp

    # ------------------------------------------------------------------ failures and state

    def set_actuator_limit(self, index: int, lower: float, upper: float) -> None:
        """Restrict actuator `index` (0..7) to [lower, upper] within its nominal range (rotor thrust cap, stuck
        surface with lower == upper, the paper's reduced rudder as +-0.2). Raises ValueError."""
        i = self._index(index)
        lower, upper = float(lower), float(upper)
        if not (math.isfinite(lower) and math.isfinite(upper)):
            raise ValueError(f"{ALLOCATED_ACTUATORS[i]}: limits must be finite, got {lower}, {upper}")
        if not LOWER_NOMINAL[i] <= lower <= upper <= UPPER_NOMINAL[i]:
            raise ValueError(
                f"{ALLOCATED_ACTUATORS[i]}: need {LOWER_NOMINAL[i]:g} <= lower <= upper <= {UPPER_NOMINAL[i]:g}, "
                f"got {lower}, {upper}"
            )
        self._lower[i], self._upper[i] = lower, upper

    def set_effectiveness(self, index: int, fraction: float) -> None:
        """Scale actuator `index`'s column of A by `fraction` in 0..1 (a surface at reduced effectiveness: its
        command keeps the full range, its moment is scaled, as the plant models it). Raises ValueError."""
        i = self._index(index)
        fraction = float(fraction)
        if not 0.0 <= fraction <= 1.0:  # also refuses NaN
            raise ValueError(f"{ALLOCATED_ACTUATORS[i]}: effectiveness must be in 0..1, got {fraction}")
        self._effectiveness[i] = fraction

    def set_wrench_weights(self, weights: Sequence[float] | np.ndarray) -> None:
        """Q = diag(weights) on (Fx, Fy, Fz, L, M, N) from the next call on (a velocity controller that leaves a
        force axis to the attitude weighs it 0). Raises ValueError for non-finite or negative weights."""
        values = np.asarray(weights, dtype=float)
        if values.shape != (N_WRENCH,) or not np.all(np.isfinite(values)) or np.any(values < 0):
            raise ValueError(f"wrench_weights must be 6 finite numbers >= 0, got {weights!r}")
        self._weights[:] = values  # in place: the CasADi buffer reads this array

    def set_failed(self, index: int) -> None:
        """Total failure of actuator `index`: its column of A is zeroed and it is held at 0."""
        i = self._index(index)
        self._effectiveness[i] = 0.0
        self._lower[i] = self._upper[i] = 0.0

    def clear(self, index: int) -> None:
        """Healthy again: nominal bounds and full effectiveness."""
        i = self._index(index)
        self._effectiveness[i] = 1.0
        self._lower[i], self._upper[i] = LOWER_NOMINAL[i], UPPER_NOMINAL[i]

    def reset(self, u: Sequence[float] | None = None) -> None:
        """Set u_trim (default zeros), clipped to the bounds, and restart the solver cold."""
        self._u[:] = 0.0 if u is None else u
        if not np.all(np.isfinite(self._u)):
            self._u[:] = 0.0
            raise ValueError(f"u must be finite, got {u!r}")
        np.clip(self._u, self._lower, self._upper, out=self._u)
        self._qp = self._new_solver()

    @staticmethod
    def _index(index: int) -> int:
        i = operator.index(index)
        if not 0 <= i < N_ACTUATORS:
            raise ValueError(f"actuator index must be 0..7 ({', '.join(ALLOCATED_ACTUATORS)}), got {index}")
        return i

    # ------------------------------------------------------------------ read-only views (copies)

    @property
    def u(self) -> np.ndarray:
        """The last solution (the next call's u_trim)."""
        return self._u.copy()

    @property
    def lower(self) -> np.ndarray:
        return self._lower.copy()

    @property
    def upper(self) -> np.ndarray:
        return self._upper.copy()

    @property
    def effectiveness(self) -> np.ndarray:
        return self._effectiveness.copy()

    @property
    def effectiveness_matrix(self) -> np.ndarray:
        """A (6 x 8) of the last allocate() call, failures included."""
        return self._jacobian.copy()

    @property
    def wrench_weights(self) -> np.ndarray:
        return self._weights.copy()
