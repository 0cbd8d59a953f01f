"""Real-time iteration (RTI) solver of the unified velocity MPC (docs/mpc.md), built once at start-up.

The paper rebuilt and solved the NLP with IPOPT at every call (~23 ms here, docs/design/solver.md). This is the
standard real-time NMPC instead: one Gauss-Newton SQP iteration per control step, warm started from the
shifted previous plan, with the QP data (RK4 gaps and their Jacobians, Gauss-Newton Hessian blocks J^T J and
gradients J^T r) from CasADi functions compiled to C, and the structured QP solved by HPIPM: by default in one
C call that writes the stage blocks into HPIPM's OCP-QP structures (autopilot/mpc/hpipm.py), or through CasADi's
`conic` interface (QpBackend.CASADI_CONIC, and the fallback where no C compiler is found). Iterated to
convergence from a fixed state, the same QP sequence is a full Gauss-Newton SQP and reaches the NLP's optimum
(tested against IPOPT). The decision vector's layout is autopilot/mpc/qp.py's.
"""

from __future__ import annotations

import enum
import math
import sys
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from aircraft.airframe import Airframe
from aircraft.codegen import BufferedFunction, compiled
from aircraft.frames import rotation_from_euler
from aircraft.wrench import body_wrench
from autopilot.control.attitude import DEFAULT_GAINS, AttitudeGains
from autopilot.mpc.horizon import PAPER, StageGrid
from autopilot.mpc.hpipm import GaussNewtonSteps, HpipmSettings, RtiStep, build_hpipm_rti
from autopilot.mpc.model import (
    CHI,
    CHI_DOT,
    NP,
    NU,
    NX,
    P_ATTITUDE_BOUND,
    P_ATTITUDE_SP_PREV,
    P_GAINS,
    P_GRID,
    P_MOMENT_BOUND,
    P_MOVE,
    P_Q_FINAL,
    P_Q_REF,
    P_SOLVER,
    P_WEIGHTS,
    P_WORKING_ROTOR,
    PSI,
    PSI_D,
    PSI_D_INDEX,
    PSI_DOT,
    PSI_INDEX,
    ROLL_PITCH,
    ROLL_PITCH_D,
    THRUST,
    MpcLimits,
    MpcWeights,
    SoftTiltCost,
    V,
    stage_residual,
    step_parameters,
    terminal_residual,
)
from autopilot.mpc.qp import build_qp_functions, stage_functions


class QpBackend(enum.Enum):
    """How the QP of each RTI is built and solved."""

    HPIPM_C = "hpipm-c"  # one C call: stage blocks into HPIPM's OCP-QP structures (falls back to CASADI_CONIC)
    CASADI_CONIC = "casadi-conic"  # one sparse QP through CasADi's `conic` HPIPM plugin


@dataclass
class MpcSolution:
    """One solve: the first stage's plan and the prediction (for telemetry)."""

    ok: bool
    status: str
    solve_time_s: float  # solve(): the call's wall time, copies included; start()/finish(): the C steps' own
    iterations: int
    x: np.ndarray  # (N+1, NX) predicted states
    u: np.ndarray  # (N, NU) planned inputs
    cost: float = math.nan


@dataclass(frozen=True)
class StageModel:
    """The stage and terminal residuals with their built-in terms bound (for the reference NLP)."""

    airframe: Airframe
    weights: MpcWeights
    soft: SoftTiltCost

    def stage_residual(self, x: ca.SX, u: ca.SX, p: ca.SX) -> ca.SX:
        return stage_residual(self.airframe, self.weights, self.soft, x, u, p)

    def terminal_residual(self, x: ca.SX, p: ca.SX) -> ca.SX:
        return terminal_residual(self.weights, x, p)


def planned_force_function(airframe: Airframe) -> ca.Function:
    """Body force (N) the plan asks of rotors + wing at a stage: the allocator's force set-point."""
    x, u = ca.SX.sym("x", NX), ca.SX.sym("u", NU)
    v_air_body = rotation_from_euler(x[PSI]).T @ x[V]
    force, _ = body_wrench(airframe, u[THRUST], x[CHI], ca.SX.zeros(4), v_air_body, ca.SX.zeros(3))
    return ca.Function("mpc_planned_force", [x, u], [force])


class RtiSolver:
    """The MPC's numerical core: bounds, warm start, one QP per call."""

    def __init__(
        self,
        airframe: Airframe,
        grid: StageGrid = PAPER.grid,
        limits: MpcLimits = MpcLimits(),
        gains: AttitudeGains = DEFAULT_GAINS,
        weights: MpcWeights = MpcWeights(),
        soft: SoftTiltCost = SoftTiltCost(),
        compile_model: bool = True,
        qp_tolerance: float = 1e-5,
        backend: QpBackend = QpBackend.HPIPM_C,
        hpipm: HpipmSettings | None = None,
        gauss_newton_steps: int = 1,
    ) -> None:
        """grid: the stages' lengths (autopilot/mpc/horizon.py; the paper's 25 x 10 ms by default).
        gauss_newton_steps: QPs per solve (1: the real-time iteration).
        qp_tolerance: HPIPM's stationarity tolerance (feasibility and complementarity 100x tighter, at least
        1e-8); 1e-5 for real time, 1e-8 to reproduce a converged NLP solution exactly. hpipm: all of HPIPM's
        settings instead (HPIPM_C only). compile_model: False keeps everything in CasADi's virtual machine (the
        CASADI_CONIC back-end). gains, the Table 2 weights and the limits can be changed later (set_tuning)."""
        self.airframe = airframe
        self.grid = grid
        if gauss_newton_steps < 1:
            raise ValueError(f"gauss_newton_steps must be at least 1, got {gauss_newton_steps}")
        self.gauss_newton_steps = gauss_newton_steps
        self.horizon = n = grid.stages
        functions = stage_functions(airframe, weights, soft, grid.substeps)
        self.step_function = functions.step
        self._step = BufferedFunction(compiled(functions.step, "vtol-autopilot") if compile_model else functions.step)
        self.model = StageModel(airframe, weights, soft)
        # The stage parameters P_SOLVER of every node: each stage's length and whether it is one tick long (the
        # delayed rate held, as the paper's stages), the attitude gains, the roll and pitch set-point flown at the
        # previous tick (set at each shift) and the weight of the move from it (the first stage's), the Table 2
        # weights and the roll and pitch bound (set_tuning); the rotors' moment bound, the working rotors and the velocity
        # weights' factor while a rotor has failed (set_actuator_limits).
        self.solver_rows = np.zeros((P_SOLVER.stop - P_SOLVER.start, n + 1))
        rows = self._solver_row
        self.solver_rows[rows(P_GRID)] = np.vstack(
            (np.append(grid.lengths_s, grid.tick_s), np.append(np.equal(grid.ticks, 1), 1.0))
        )
        self.solver_rows[rows(P_MOVE), 0] = 1.0
        self.solver_rows[rows(P_WORKING_ROTOR)] = 1.0
        self._shift_interval, self._shift_fraction = grid.shift_sources()
        # The interval's far node, and the input in force at each new stage's start (the last repeated).
        self._shift_next = np.minimum(self._shift_interval + 1, self.horizon)
        self._shift_input = np.minimum(self._shift_interval[: self.horizon], self.horizon - 1)
        self.n_w = NX * (n + 1) + NU * n
        self.weights, self.limits = weights, limits
        self._limits_key: np.ndarray | None = None
        self.set_tuning(gains, weights, limits)
        settings = hpipm or HpipmSettings.for_tolerance(qp_tolerance)
        self.fast = None
        self.last_step: RtiStep | None = None  # the C back-end's last QP: iterations, residuals, where the time went
        if backend is QpBackend.HPIPM_C and compile_model:
            (x_lb, x_ub), (u_lb, u_ub) = self._x_bounds, self._u_bounds
            state_bounded = np.isfinite(x_lb) | np.isfinite(x_ub)
            input_bounded = np.isfinite(u_lb) | np.isfinite(u_ub)
            self.fast = build_hpipm_rti(functions, n, state_bounded, input_bounded, limits.yaw_sp_offset, settings)
            if self.fast is None:
                print("vtol-autopilot: the MPC's QP goes through CasADi's conic interface (slower)", file=sys.stderr)
        self.backend = QpBackend.HPIPM_C if self.fast is not None else QpBackend.CASADI_CONIC
        if self.fast is None:
            qp_data = build_qp_functions(functions, n, limits)
            self.qp_data = compiled(qp_data, "vtol-autopilot") if compile_model else qp_data
            options = {
                "N": n, "nx": [NX] * (n + 1), "nu": [NU] * n + [0], "ng": [1] * n + [0],
                "error_on_fail": False,
                "hpipm": {"mode": "speed_abs", "iter_max": settings.iter_max, "res_g_max": settings.tol_stat,
                          "res_b_max": settings.tol_eq, "res_d_max": settings.tol_ineq,
                          "res_m_max": settings.tol_comp},
            }  # fmt: skip
            self.qp = ca.conic(
                "mpc_qp", "hpipm", {"h": qp_data.sparsity_out("H"), "a": qp_data.sparsity_out("A")}, options
            )
        self.w = np.zeros(self.n_w)
        self.params = np.zeros((NP, n + 1))
        self.initialised = False
        self.levenberg = 1.0
        self._finished: MpcSolution | None = None  # start() without the C back-end: solved at once

    # ---- tuning -------------------------------------------------------------------------------------------
    def set_tuning(self, gains: AttitudeGains, weights: MpcWeights, limits: MpcLimits) -> None:
        """The attitude loop's gains, the Table 2 weights and the limits from the next solve on. The problem's
        structure is built in: `weights` may differ from the built ones only in the Table 2 weights, `limits` not in
        yaw_sp_offset (ValueError otherwise)."""
        if weights.built_in() != self.weights.built_in():
            raise ValueError("only the Table 2 weights of an MPC can change once it is built")
        if limits.yaw_sp_offset != self.limits.yaw_sp_offset:
            raise ValueError("the MPC's yaw set-point offset is built into its QP")
        self.gains, self.weights, self.limits = gains, weights, limits
        rows = self._solver_row
        self.solver_rows[rows(P_GAINS)] = gains.vector()[:, None]
        self.solver_rows[rows(P_WEIGHTS)] = weights.table_2_rows()[:, None]
        self.solver_rows[rows(P_ATTITUDE_BOUND)] = np.array(limits.attitude)[:, None]
        self._one_tick = step_parameters(self.grid.tick_s, True, gains.vector())
        self.lbw, self.ubw = self._nominal_bounds()
        if self._limits_key is not None:  # the failure-aware bounds again, on the new nominal ones
            key, self._limits_key = self._limits_key, None
            self.set_actuator_limits(key[0:4], key[4:8], key[8:12], key[12:16])

    def predict_tick(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The model's state one controller tick after x under the input u (a copy)."""
        return self._step(x, u, self._one_tick)[0].copy()

    # ---- bounds -------------------------------------------------------------------------------------------
    def _nominal_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lim, a = self.limits, self.airframe
        x_lb = np.full(NX, -np.inf)
        x_ub = np.full(NX, np.inf)
        x_lb[V], x_ub[V] = -np.array(lim.velocity), lim.velocity
        x_lb[CHI], x_ub[CHI] = a.tilt_min, a.tilt_max
        if self.weights.q_attitude_bound <= 0:  # else the roll and pitch bound is soft (docs/mpc.md, deviation 6)
            x_lb[ROLL_PITCH], x_ub[ROLL_PITCH] = -np.array(lim.attitude), lim.attitude
        x_lb[PSI_DOT], x_ub[PSI_DOT] = -lim.rate, lim.rate
        u_lb = np.full(NU, -np.inf)
        u_ub = np.full(NU, np.inf)
        u_lb[CHI_DOT], u_ub[CHI_DOT] = -lim.tilt_rate, lim.tilt_rate
        u_lb[THRUST], u_ub[THRUST] = 0.0, a.thrust_planned_max
        u_lb[ROLL_PITCH_D], u_ub[ROLL_PITCH_D] = -np.array(lim.attitude_sp), lim.attitude_sp
        self._x_bounds, self._u_bounds = (x_lb, x_ub), (u_lb, u_ub)
        return self._stack(x_lb, u_lb), self._stack(x_ub, u_ub)

    def _stack(self, x_part: np.ndarray, u_part: np.ndarray) -> np.ndarray:
        return np.concatenate([np.concatenate((x_part, u_part))] * self.horizon + [x_part])

    def set_actuator_limits(
        self,
        thrust_max: np.ndarray,
        tilt_fixed: np.ndarray,
        thrust_min: np.ndarray | None = None,
        tilt_rate_scale: np.ndarray | None = None,
    ) -> None:
        """Failure awareness (docs/mpc.md, the solver, failures): per-rotor thrust ceilings and floors (N; a stuck motor has both at its
        thrust), stuck tilts (rad, NaN = free) and per-servo tilt-rate fractions (a slowed servo)."""
        thrust_min = np.zeros(4) if thrust_min is None else thrust_min
        tilt_rate_scale = np.ones(4) if tilt_rate_scale is None else tilt_rate_scale
        key = np.concatenate((thrust_max, tilt_fixed, thrust_min, tilt_rate_scale))
        if self._limits_key is not None and np.array_equal(key, self._limits_key, equal_nan=True):
            return
        self._limits_key = key
        (x_lb, x_ub), (u_lb, u_ub) = (b.copy() for b in self._x_bounds), (b.copy() for b in self._u_bounds)
        u_ub[THRUST] = np.minimum(u_ub[THRUST], thrust_max)
        u_lb[THRUST] = np.minimum(np.maximum(u_lb[THRUST], thrust_min), u_ub[THRUST])
        u_lb[CHI_DOT] = u_lb[CHI_DOT] * tilt_rate_scale
        u_ub[CHI_DOT] = u_ub[CHI_DOT] * tilt_rate_scale
        # A stuck servo's tilt rate is zero, so its planned tilt stays at x_0's, the servo estimate's. Its tilt is
        # not also bounded to the stuck angle: the servo drives there with its own lag (the estimate converges in
        # ~0.1 s), and x_0 != the stuck angle with zero rate made every QP infeasible right after a jam.
        stuck = ~np.isnan(tilt_fixed)
        u_lb[CHI_DOT] = np.where(stuck, 0.0, u_lb[CHI_DOT])
        u_ub[CHI_DOT] = np.where(stuck, 0.0, u_ub[CHI_DOT])
        self.lbw, self.ubw = self._stack(x_lb, u_lb), self._stack(x_ub, u_ub)
        # A rotor limited or a tilt stuck: the rotors' thrusts, planned for force, make moments the allocator cannot
        # cancel with the thrusts the force leaves it; the surfaces can.
        rotor_failed = bool(np.any(thrust_max < self.airframe.thrust_planned_max) or np.any(thrust_min > 0.0))
        weight = max(self.weights.q_moment_bound if rotor_failed else 0.0,
                     self.weights.q_moment_bound_servo if np.any(stuck) else 0.0)  # fmt: skip
        self.solver_rows[self._solver_row(P_MOMENT_BOUND)] = math.sqrt(weight)
        self.solver_rows[self._solver_row(P_WORKING_ROTOR)] = (thrust_max > 0.0)[:, None]
        factor = self.weights.q_velocity_rotor_failed if rotor_failed else 1.0
        horizontal = np.array([factor, factor, 1.0])
        self.solver_rows[self._solver_row(P_Q_REF)] = (np.array(self.weights.q_ref) * horizontal)[:, None]
        self.solver_rows[self._solver_row(P_Q_FINAL)] = (np.array(self.weights.q_final) * horizontal)[:, None]

    # ---- solving ------------------------------------------------------------------------------------------
    def states(self) -> np.ndarray:
        """The planned states (N+1, NX), a copy."""
        stride, n = NX + NU, self.horizon
        return np.concatenate((self.w[: n * stride].reshape(n, stride)[:, :NX], self.w[None, n * stride :]))

    def inputs(self) -> np.ndarray:
        """The planned inputs (N, NU), a copy."""
        stride, n = NX + NU, self.horizon
        return self.w[: n * stride].reshape(n, stride)[:, NX:].copy()

    def initialise(self, x0: np.ndarray, hover_thrust: float) -> None:
        """A cold guess: the state held, hover thrust, attitude set-point at the current attitude."""
        u = np.zeros(NU)
        u[THRUST] = hover_thrust
        u[PSI_D] = x0[PSI]
        stride = NX + NU
        for k in range(self.horizon):
            self.w[k * stride : k * stride + NX] = x0
            self.w[k * stride + NX : (k + 1) * stride] = u
        self.w[self.horizon * stride :] = x0
        self._remember_flown_attitude_sp()
        self.initialised = True

    @staticmethod
    def _solver_row(rows: slice | int) -> slice | int:
        """Stage-parameter rows (P_GRID, P_MOVE ...) as rows of solver_rows."""
        if isinstance(rows, slice):
            return slice(rows.start - P_SOLVER.start, rows.stop - P_SOLVER.start)
        return rows - P_SOLVER.start

    def stage_parameters(self, params: np.ndarray) -> np.ndarray:
        """The stage parameters (NP, N+1) with the rows this solver keeps (P_SOLVER) written in, a copy."""
        full = np.array(params, dtype=float)
        full[P_SOLVER] = self.solver_rows
        return full

    def _remember_flown_attitude_sp(self) -> None:
        """The plan's first roll and pitch set-point, the one flown: the move suppression's reference next tick."""
        flown = self.w[NX + ROLL_PITCH_D.start : NX + ROLL_PITCH_D.stop]
        self.solver_rows[self._solver_row(P_ATTITUDE_SP_PREV), :] = flown[:, None]

    def shift(self) -> None:
        """Warm start for the next step: the plan moved one tick (the first stage's length) forward. On the
        paper's grid that is one stage; on a longer stage the states are interpolated and the input is the one
        in force at the new node's time. The last input is repeated past the end, the new terminal state its
        dynamics over one tick."""
        stride, n = NX + NU, self.horizon
        self._remember_flown_attitude_sp()
        states = self.states()
        inputs = self.inputs()
        j, f = self._shift_interval, self._shift_fraction
        moved = states[j] + f[:, None] * (states[self._shift_next] - states[j])
        moved[n] = self.predict_tick(states[n], inputs[n - 1])
        stages = self.w[: n * stride].reshape(n, stride)
        stages[:, :NX] = moved[:n]
        stages[:, NX:] = inputs[self._shift_input]
        self.w[n * stride :] = moved[n]

    def shift_yaw(self, delta: float) -> None:
        """Add delta (rad) to the yaw of every planned state and yaw set-point: the same plan, since the cost,
        the attitude law and the yaw set-point rows see yaw only through differences and wrapped angles."""
        stride = NX + NU
        self.w[PSI_INDEX::stride] += delta
        self.w[NX + PSI_D_INDEX :: stride] += delta

    def solve(self, x0: np.ndarray, params: np.ndarray) -> MpcSolution:
        """One RTI (`gauss_newton_steps` of them at the same state, default one): linearise at the current guess,
        solve the QP, take the full step."""
        started = time.perf_counter()
        self._set_params(params)
        if self.fast is not None:
            steps = self.fast.iterate(self.w, self.params, x0, self.lbw, self.ubw, self.levenberg,
                                      self.gauss_newton_steps)  # fmt: skip
            return self._solution(steps, time.perf_counter() - started)
        qp_iterations = 0
        for _ in range(self.gauss_newton_steps):
            ok, status, iterations, cost = self._conic_step(x0)
            qp_iterations += iterations
            if not ok:
                break
        elapsed = time.perf_counter() - started
        return MpcSolution(ok, status, elapsed, qp_iterations, self.states(), self.inputs(), cost)

    def start(self, x0: np.ndarray, params: np.ndarray) -> None:
        """`solve` on the C back-end's worker thread (docs/mpc.md, options): returns at once, `finish` waits for it and
        gives the solution; meanwhile the plan (`w`, `states()`) is the guess it started from. Without the C back-end
        the solve runs here, now."""
        if self.fast is None:
            if self._finished is not None:
                raise RuntimeError("a solve is running: finish() it first")
            self._finished = self.solve(x0, params)
            return
        self._set_params(params)
        self.fast.start(self.w, self.params, x0, self.lbw, self.ubw, self.levenberg, self.gauss_newton_steps)

    def finish(self) -> MpcSolution:
        """The solution of the solve `start` began."""
        if self.fast is None:
            solution, self._finished = self._finished, None
            if solution is None:
                raise RuntimeError("no solve was started")
            return solution
        steps = self.fast.finish(self.w)
        return self._solution(steps, steps.wall_s)

    def _set_params(self, params: np.ndarray) -> None:
        self.params[:] = params
        self.params[P_SOLVER] = self.solver_rows

    def _solution(self, steps: GaussNewtonSteps, elapsed_s: float) -> MpcSolution:
        step = self.last_step = steps.last
        return MpcSolution(steps.ok, step.status_name, elapsed_s, steps.iterations, self.states(), self.inputs(),
                           step.cost)  # fmt: skip

    def _conic_step(self, x0: np.ndarray) -> tuple[bool, str, int, float]:
        """One Gauss-Newton step through CasADi's conic interface (no C back-end)."""
        H, g, A, lba, uba, lbx, ubx, qp_cost = self.qp_data(self.w, self.params, x0, self.lbw, self.ubw, self.levenberg)
        result = self.qp(h=H, g=g, a=A, lba=lba, uba=uba, lbx=lbx, ubx=ubx)
        stats = self.qp.stats()
        dw = np.asarray(result["x"]).ravel()
        ok, status = bool(stats.get("success", False)), str(stats.get("return_status", ""))
        ok = ok and bool(np.all(np.isfinite(dw)))
        if ok:
            self.w += dw
        return ok, status, int(stats.get("iter_count", -1)), float(qp_cost)
