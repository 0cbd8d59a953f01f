"""The QP of one real-time iteration of the unified MPC (docs/mpc.md), as CasADi functions.

`stage_functions` gives the per-stage blocks (RK4 gap and its Jacobians, Gauss-Newton Hessian J^T J and gradient
J^T r, cost) that both QP back-ends use: the C driver (autopilot/mpc/rti.c) writes them into HPIPM's
OCP-QP structures stage by stage; `build_qp_functions` assembles them into the one sparse QP that CasADi's
`conic` interface takes (the fallback without a C compiler).

Decision vector w = [x0 u0 x1 u1 ... x_{N-1} u_{N-1} xN] (HPIPM's ordering); constraint rows
[gap0 lin0 gap1 lin1 ... gap_{N-1} lin_{N-1}] with gap_k = F(x_k, u_k) - x_{k+1} and lin_k = psi_d,k - psi_k.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from aircraft.airframe import Airframe
from autopilot.mpc.model import (
    NP,
    NU,
    NX,
    P_STEP,
    PSI_D_INDEX,
    PSI_INDEX,
    MpcLimits,
    MpcWeights,
    SoftTiltCost,
    discrete_dynamics,
    stage_residual,
    terminal_residual,
)


@dataclass(frozen=True)
class StageFunctions:
    """stage(x, u, x_next, p) -> (gap, A, B, H, g, cost); terminal(x, p) -> (H, g, cost); step(x, u, step) -> x_next
    (step: the stage parameters P_STEP, its length, rate_held and the attitude gains). H and g are in the stage's
    variables [x; u] (terminal: x); outputs keep their structural zeros."""

    stage: ca.Function
    terminal: ca.Function
    step: ca.Function


def stage_functions(
    airframe: Airframe,
    weights: MpcWeights = MpcWeights(),
    soft: SoftTiltCost = SoftTiltCost(),
    substeps: int = 1,
) -> StageFunctions:
    """substeps: RK4 steps per stage (StageGrid.substeps). The gains, the Table 2 weights and the attitude bound are
    stage parameters; `weights` gives the terms built in (MpcWeights)."""
    step = discrete_dynamics(airframe, substeps)
    xs, us, xn, ps = ca.SX.sym("x", NX), ca.SX.sym("u", NU), ca.SX.sym("x_next", NX), ca.SX.sym("p", NP)
    x_next = step(xs, us, ps[P_STEP])
    residual = stage_residual(airframe, weights, soft, xs, us, ps)
    jac = ca.jacobian(residual, ca.vertcat(xs, us))
    outputs = [x_next - xn, ca.jacobian(x_next, xs), ca.jacobian(x_next, us), jac.T @ jac, jac.T @ residual,
               ca.sumsqr(residual)]  # fmt: skip
    stage = ca.Function("mpc_stage", [xs, us, xn, ps], outputs)
    r_terminal = terminal_residual(weights, xs, ps)
    j_terminal = ca.jacobian(r_terminal, xs)
    terminal_outputs = [j_terminal.T @ j_terminal, j_terminal.T @ r_terminal, ca.sumsqr(r_terminal)]
    terminal = ca.Function("mpc_terminal", [xs, ps], terminal_outputs)
    return StageFunctions(stage, terminal, step)


def build_qp_functions(functions: StageFunctions, horizon: int, limits: MpcLimits = MpcLimits()) -> ca.Function:
    """qp_data(w, P, x0, lbw, ubw, levenberg) -> (H, g, A, lba, uba, lbx, ubx, cost) for the QP in the step dw."""
    stage, terminal = functions.stage, functions.terminal
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
    # tracks wrongly, docs/design/solver.md).
    dx0 = x0 - w[0:NX]
    lbx = ca.vertcat(dx0, lbx[NX:])
    ubx = ca.vertcat(dx0, ubx[NX:])
    total_cost = ca.sum2(costs) + cost_terminal
    qp_data = ca.Function(
        "mpc_qp_data", [w, params, x0, lbw, ubw, levenberg],
        [hessian, gradient, constraint_matrix, ca.vertcat(*lba), ca.vertcat(*uba), lbx, ubx, total_cost],
        ["w", "P", "x0", "lbw", "ubw", "levenberg"], ["H", "g", "A", "lba", "uba", "lbx", "ubx", "cost"],
    )  # fmt: skip
    return qp_data
