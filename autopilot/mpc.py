"""Real-time iteration (RTI) solver of the unified velocity MPC (docs/mpc.md 3), built once at start-up.

The paper rebuilt and solved the NLP with IPOPT at every call (~23 ms here, docs/performance.md). This is the
standard real-time NMPC instead: one Gauss-Newton SQP iteration per control step, warm started from the
shifted previous plan, with the QP data (RK4 gaps and their Jacobians, Gauss-Newton Hessian blocks J^T J and
gradients J^T r) from one CasADi function compiled to C, and the structured QP solved by HPIPM through
CasADi's `conic` interface. Iterated to convergence from a fixed state, the same QP sequence is a full
Gauss-Newton SQP and reaches the NLP's optimum (tested against IPOPT).

Decision vector w = [x0 u0 x1 u1 ... x_{N-1} u_{N-1} xN] (HPIPM's ordering); constraint rows
[gap0 lin0 gap1 lin1 ... gap_{N-1} lin_{N-1}] with gap_k = F(x_k, u_k) - x_{k+1} and lin_k = psi_d,k - psi_k.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from aircraft.airframe import Airframe
from aircraft.codegen import compiled
from aircraft.frames import rotation_from_euler
from aircraft.wrench import body_wrench
from autopilot.attitude import DEFAULT_GAINS, AttitudeGains
from autopilot.mpc_model import (
    CHI,
    CHI_DOT,
    NP,
    NU,
    NX,
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
    discrete_dynamics,
    stage_residual,
    terminal_residual,
)


@dataclass
class MpcSolution:
    """One solve: the first stage's plan and the prediction (for telemetry)."""

    ok: bool
    status: str
    solve_time_s: float
    iterations: int
    x: np.ndarray  # (N+1, NX) predicted states
    u: np.ndarray  # (N, NU) planned inputs
    cost: float = math.nan


@dataclass
class MpcStatistics:
    solve_times_s: list[float] = field(default_factory=list)
    failed: int = 0


def build_qp_functions(
    airframe: Airframe,
    horizon: int,
    dt: float,
    gains: AttitudeGains = DEFAULT_GAINS,
    weights: MpcWeights = MpcWeights(),
    soft: SoftTiltCost = SoftTiltCost(),
    limits: MpcLimits = MpcLimits(),
) -> tuple[ca.Function, ca.Function]:
    """qp_data(w, P, x0, lbw, ubw) -> (H, g, A, lba, uba, lbx, ubx, cost) for the QP in the step dw,
    and the plain dynamics F(x, u) (used for shifting and tests)."""
    step = discrete_dynamics(airframe, gains, dt)
    xs, us, xn, ps = ca.SX.sym("x", NX), ca.SX.sym("u", NU), ca.SX.sym("x_next", NX), ca.SX.sym("p", NP)
    x_next = step(xs, us)
    residual = stage_residual(airframe, weights, soft, xs, us, ps, limits)
    jac = ca.jacobian(residual, ca.vertcat(xs, us))
    stage = ca.Function(
        "mpc_stage", [xs, us, xn, ps],
        [x_next - xn, ca.jacobian(x_next, xs), ca.jacobian(x_next, us), jac.T @ jac, jac.T @ residual,
         ca.sumsqr(residual)],
    )  # fmt: skip
    r_terminal = terminal_residual(weights, xs, ps, limits)
    j_terminal = ca.jacobian(r_terminal, xs)
    terminal = ca.Function("mpc_terminal", [xs, ps], [j_terminal.T @ j_terminal, j_terminal.T @ r_terminal,
                                                      ca.sumsqr(r_terminal)])  # fmt: skip

    n = horizon
    n_w = NX * (n + 1) + NU * n
    w = ca.MX.sym("w", n_w)
    params = ca.MX.sym("P", NP, n + 1)
    x0 = ca.MX.sym("x0", NX)
    lbw, ubw = ca.MX.sym("lbw", n_w), ca.MX.sym("ubw", n_w)
    stride = NX + NU
    xs_all = ca.horzcat(*[w[k * stride : k * stride + NX] for k in range(n + 1)])
    us_all = ca.horzcat(*[w[k * stride + NX : (k + 1) * stride] for k in range(n)])
    gaps, a_blocks, b_blocks, h_blocks, g_blocks, costs = stage.map(n, "serial")(
        xs_all[:, 0:n], us_all, xs_all[:, 1 : n + 1], params[:, 0:n]
    )
    h_terminal, g_terminal, cost_terminal = terminal(xs_all[:, n], params[:, n])

    stage_width = NX + NU
    h_list = [h_blocks[:, k * stage_width : (k + 1) * stage_width] for k in range(n)] + [h_terminal]
    # Levenberg-Marquardt damping, Marquardt's scale-invariant form H + lambda diag(H) (+ a tiny floor): full
    # Gauss-Newton steps can cycle between the linear and the saturated part of the attitude loop's rate
    # limit; a multiple of I instead froze the variables with small curvature (thrust in N) (docs/mpc.md).
    levenberg = ca.MX.sym("levenberg")
    gauss_newton = ca.diagcat(*h_list)
    hessian = gauss_newton + ca.diag(levenberg * ca.diag(gauss_newton) + 1e-6)
    gradient = ca.vertcat(*[g_blocks[:, k] for k in range(n)], g_terminal)

    rows, lba, uba = [], [], []
    lin_row = ca.DM.zeros(1, stage_width)
    lin_row[PSI_INDEX], lin_row[NX + PSI_D_INDEX] = -1.0, 1.0
    for k in range(n):
        left = k * stride
        right = n_w - left - stride - NX
        a_k = a_blocks[:, k * NX : (k + 1) * NX]
        b_k = b_blocks[:, k * NU : (k + 1) * NU]
        rows.append(ca.horzcat(ca.MX(NX, left), a_k, b_k, -ca.MX.eye(NX), ca.MX(NX, right)))
        rows.append(ca.horzcat(ca.MX(1, left), ca.MX(lin_row), ca.MX(1, n_w - left - stage_width)))
        lba.append(-gaps[:, k])
        uba.append(-gaps[:, k])
        offset = us_all[PSI_D_INDEX, k] - xs_all[PSI_INDEX, k]
        lba.append(-limits.yaw_sp_offset - offset)
        uba.append(limits.yaw_sp_offset - offset)
    constraint_matrix = ca.vertcat(*rows)
    lbx = lbw - w
    ubx = ubw - w
    # The initial state is not free: its step is fixed to reach the measurement (dx0 = x0 - w0; a free dx0
    # tracks wrongly, docs/performance.md).
    dx0 = x0 - w[0:NX]
    lbx = ca.vertcat(dx0, lbx[NX:])
    ubx = ca.vertcat(dx0, ubx[NX:])
    total_cost = ca.sum2(costs) + cost_terminal
    qp_data = ca.Function(
        "mpc_qp_data", [w, params, x0, lbw, ubw, levenberg],
        [hessian, gradient, constraint_matrix, ca.vertcat(*lba), ca.vertcat(*uba), lbx, ubx, total_cost],
        ["w", "P", "x0", "lbw", "ubw", "levenberg"], ["H", "g", "A", "lba", "uba", "lbx", "ubx", "cost"],
    )  # fmt: skip
    return qp_data, step


@dataclass(frozen=True)
class StageModel:
    """The stage and terminal residuals with their weights bound (for the reference NLP)."""

    airframe: Airframe
    weights: MpcWeights
    soft: SoftTiltCost
    limits: MpcLimits = MpcLimits()

    def stage_residual(self, x: ca.SX, u: ca.SX, p: ca.SX) -> ca.SX:
        return stage_residual(self.airframe, self.weights, self.soft, x, u, p, self.limits)

    def terminal_residual(self, x: ca.SX, p: ca.SX) -> ca.SX:
        return terminal_residual(self.weights, x, p, self.limits)


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
        horizon: int = 25,
        dt: float = 0.01,
        limits: MpcLimits = MpcLimits(),
        gains: AttitudeGains = DEFAULT_GAINS,
        weights: MpcWeights = MpcWeights(),
        soft: SoftTiltCost = SoftTiltCost(),
        compile_model: bool = True,
        qp_tolerance: float = 1e-5,
    ) -> None:
        """qp_tolerance: HPIPM's stationarity tolerance (feasibility and complementarity 100x tighter, at least
        1e-8); 1e-5 for real time, 1e-8 to reproduce a converged NLP solution exactly."""
        self.airframe = airframe
        self.gains = gains
        self.horizon = horizon
        self.dt = dt
        self.limits = limits
        qp_data, self.step_function = build_qp_functions(airframe, horizon, dt, gains, weights, soft, limits)
        self.model = StageModel(airframe, weights, soft, limits)
        self.weights = weights
        self.qp_data = compiled(qp_data, "vtol-autopilot") if compile_model else qp_data
        n = horizon
        self.n_w = NX * (n + 1) + NU * n
        feasibility = max(qp_tolerance / 100, 1e-8)
        options = {
            "N": n, "nx": [NX] * (n + 1), "nu": [NU] * n + [0], "ng": [1] * n + [0],
            "error_on_fail": False,
            "hpipm": {"mode": "speed_abs", "iter_max": 50, "res_g_max": qp_tolerance,
                      "res_b_max": feasibility, "res_d_max": feasibility, "res_m_max": feasibility},
        }  # fmt: skip
        self.qp = ca.conic(
            "mpc_qp", "hpipm", {"h": qp_data.sparsity_out("H"), "a": qp_data.sparsity_out("A")}, options
        )
        self.w = np.zeros(self.n_w)
        self.params = np.zeros((NP, n + 1))
        self.lbw, self.ubw = self._nominal_bounds()
        self._limits_key: np.ndarray | None = None
        self.initialised = False
        self.levenberg = 1.0

    # ---- bounds -------------------------------------------------------------------------------------------
    def _nominal_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lim, a = self.limits, self.airframe
        x_lb = np.full(NX, -np.inf)
        x_ub = np.full(NX, np.inf)
        x_lb[V], x_ub[V] = -np.array(lim.velocity), lim.velocity
        x_lb[CHI], x_ub[CHI] = a.tilt_min, a.tilt_max
        if self.weights.q_attitude_bound <= 0:  # else the roll and pitch bound is soft, in the cost (docs/mpc.md 2.8)
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
        """Failure awareness (docs/mpc.md 3.5): per-rotor thrust ceilings and floors (N; a stuck motor has both at its
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

    # ---- solving ------------------------------------------------------------------------------------------
    def states(self) -> np.ndarray:
        stride = NX + NU
        return np.stack([self.w[k * stride : k * stride + NX] for k in range(self.horizon + 1)])

    def inputs(self) -> np.ndarray:
        stride = NX + NU
        return np.stack([self.w[k * stride + NX : (k + 1) * stride] for k in range(self.horizon)])

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
        self.initialised = True

    def shift(self) -> None:
        """Warm start for the next step: the plan moved one stage forward; the last input is repeated and the
        new terminal state is its dynamics."""
        stride, n = NX + NU, self.horizon
        old = self.w.copy()
        self.w[0 : (n - 1) * stride] = old[stride : n * stride]
        self.w[(n - 1) * stride : (n - 1) * stride + NX] = old[n * stride :]
        u_last = old[(n - 1) * stride + NX : n * stride]
        self.w[n * stride :] = np.asarray(self.step_function(old[n * stride :], u_last)).ravel()

    def shift_yaw(self, delta: float) -> None:
        """Add delta (rad) to the yaw of every planned state and yaw set-point: the same plan, since the cost,
        the attitude law and the yaw set-point rows see yaw only through differences and wrapped angles."""
        stride = NX + NU
        self.w[PSI_INDEX::stride] += delta
        self.w[NX + PSI_D_INDEX :: stride] += delta

    def solve(self, x0: np.ndarray, params: np.ndarray) -> MpcSolution:
        """One RTI: linearise at the current guess, solve the QP, take the full step."""
        started = time.perf_counter()
        self.params[:] = params
        H, g, A, lba, uba, lbx, ubx, cost = self.qp_data(self.w, self.params, x0, self.lbw, self.ubw, self.levenberg)
        result = self.qp(h=H, g=g, a=A, lba=lba, uba=uba, lbx=lbx, ubx=ubx)
        stats = self.qp.stats()
        dw = np.asarray(result["x"]).ravel()
        ok = bool(stats.get("success", False)) and bool(np.all(np.isfinite(dw)))
        if ok:
            self.w += dw
        elapsed = time.perf_counter() - started
        return MpcSolution(
            ok, str(stats.get("return_status", "")), elapsed, int(stats.get("iter_count", -1)),
            self.states(), self.inputs(), float(cost),
        )  # fmt: skip


def solve_reference_nlp(solver: RtiSolver, x0: np.ndarray, params: np.ndarray, tol: float = 1e-10) -> np.ndarray:
    """The same NLP solved the paper's way: built afresh and solved to convergence by IPOPT from a cold start.

    Same dynamics, cost (sum of the squared residuals) and constraints as the RTI; returns the optimal w.
    Used by the agreement test and by the benchmark's "paper's way" figure (whose time includes the build).
    """
    n, stride = solver.horizon, NX + NU
    w = ca.SX.sym("w", solver.n_w)
    xs = [w[k * stride : k * stride + NX] for k in range(n + 1)]
    us = [w[k * stride + NX : (k + 1) * stride] for k in range(n)]
    model = solver.model
    cost = 0
    constraints = [xs[0] - x0]
    lbg, ubg = [0.0] * NX, [0.0] * NX
    for k in range(n):
        cost += ca.sumsqr(model.stage_residual(xs[k], us[k], params[:, k]))
        constraints.append(solver.step_function(xs[k], us[k]) - xs[k + 1])
        lbg += [0.0] * NX
        ubg += [0.0] * NX
        constraints.append(us[k][PSI_D_INDEX] - xs[k][PSI_INDEX])
        lbg.append(-solver.limits.yaw_sp_offset)
        ubg.append(solver.limits.yaw_sp_offset)
    cost += ca.sumsqr(model.terminal_residual(xs[n], params[:, n]))
    nlp = ca.nlpsol(
        "paper_nlp", "ipopt", {"x": w, "f": cost, "g": ca.vertcat(*constraints)},
        {"ipopt.print_level": 0, "print_time": False, "ipopt.tol": tol, "ipopt.max_iter": 500},
    )  # fmt: skip
    cold = np.zeros(solver.n_w)
    for k in range(n + 1):
        cold[k * stride : k * stride + NX] = x0
    result = nlp(x0=cold, lbx=solver.lbw, ubx=solver.ubw, lbg=lbg, ubg=ubg)
    if not nlp.stats()["success"]:
        raise RuntimeError(f"IPOPT did not converge: {nlp.stats()['return_status']}")
    return np.asarray(result["x"]).ravel()
