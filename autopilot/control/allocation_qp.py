"""The allocation QP as CasADi functions of the shared model (docs/autopilot.md), generated to C by the
allocator (autopilot/control/allocation.py).

At every call the allocator linearises the shared model W(u) = aircraft.wrench.actuator_wrench(u; tilts, v_air_body, rates_body)
(force N and moment N m in body FRD, gravity excluded, wing aerodynamics included) at the previous solution
u_trim and solves the box-constrained least-squares QP of docs/autopilot.md (the paper's "Control Allocation"
paragraph only says that a QP distributes the wrench W^B over all actuators at once; it gives no equation)

    min_du  1/2 (A du - dW)^T Q (A du - dW) + eps/2 ||u_trim + du||^2      s.t.  lb - u_trim <= du <= ub - u_trim

    A  = dW/du at u_trim (6 x 8, CasADi Jacobian of the model: no second copy of the physics)
    dW = W_sp - W(u_trim)
    Q  = diag(wrench_weights), default identity (1 N weighs like 1 N m: the rotor arms are ~1 m). Raise the
         moment weights to give attitude priority over force when the demand is infeasible.
    eps = least_effort * max(1, max_j (A^T A)_jj): relative least-effort regularisation on the command u itself
         (relative to the unweighted A, so that the row weights do not scale it).
         It makes the Hessian H = A^T Q A + eps I positive definite (surface columns vanish at zero airspeed, and a
         failed actuator's column is zero) and, among equally good commands, picks the least-norm one (the paper's
         "least-norm solution"): redundant rotors share the work instead of keeping whatever split the history
         left (with eps ||du||^2 alone, the front rotors stayed parked at 0 in cruise). W is affine in u, so each
         call solves the whole problem, not a step of it. The price is a relative residual of about
         eps / (sigma^2 + eps) along each singular direction sigma of sqrt(Q) A (default 1e-6: ~2e-4 for yaw in
         hover, the weakest axis).
"""

from __future__ import annotations

import casadi as ca

from aircraft.actuators import ALLOCATED_COUNT
from aircraft.airframe import Airframe
from aircraft.wrench import actuator_wrench

N_ACTUATORS = ALLOCATED_COUNT
N_WRENCH = 6


def build_allocation_functions(airframe: Airframe) -> tuple[ca.Function, ca.Function]:
    """CasADi functions of the allocation, from aircraft.wrench.actuator_wrench (built once, SX).

    allocation_qp(u_trim, effectiveness, tilts, v_air_body, rates_body, wrench_sp, wrench_weights, least_effort,
                  lower, upper) -> (H (8x8), g, l_box, u_box, A (6x8), W(u_trim)), all dense;
    allocation_wrench(u, effectiveness, tilts, v_air_body, rates_body, wrench_sp, wrench_weights, least_effort,
                      lower, upper) -> (W(u), optimality gap at u).
    The optimality gap is the projected gradient step |u - clip(u - g(u) / h, lower, upper)|_inf of the QP's
    objective at u, with h the largest diagonal entry of H: 0 at the optimum, else roughly how far (in actuator
    units) the stiffest actuator is from where the objective wants it.
    `effectiveness` scales each actuator inside the model, W(effectiveness * u), so A's column j is scaled by it.
    """
    u = ca.SX.sym("u", N_ACTUATORS)
    effectiveness = ca.SX.sym("effectiveness", N_ACTUATORS)
    tilts = ca.SX.sym("tilts", 4)
    v_air = ca.SX.sym("v_air_body", 3)
    rates = ca.SX.sym("rates_body", 3)
    wrench_sp = ca.SX.sym("wrench_sp", N_WRENCH)
    weights = ca.SX.sym("wrench_weights", N_WRENCH)
    least_effort = ca.SX.sym("least_effort")
    lower = ca.SX.sym("lower", N_ACTUATORS)
    upper = ca.SX.sym("upper", N_ACTUATORS)

    wrench = actuator_wrench(airframe, effectiveness * u, tilts, v_air, rates)
    jacobian = ca.jacobian(wrench, u)  # A, 6 x 8; the wrench is affine in u for fixed tilts and airspeed
    weighted = ca.diag(weights) @ jacobian  # Q A
    hessian_ls = jacobian.T @ weighted  # A^T Q A
    # Relative to the unweighted A^T A, so that raising the moment weights does not raise the regularisation.
    eps = least_effort * ca.fmax(1.0, ca.mmax(ca.sum1(jacobian * jacobian)))
    hessian = hessian_ls + eps * ca.SX.eye(N_ACTUATORS)
    # g = -A^T Q dW + eps u_trim: the least-effort term acts on the command u = u_trim + du itself (paper: "the
    # least-norm solution"), not only on the change du, so redundant actuators share the work (equal rotors)
    # instead of keeping whatever split the history left them in.
    gradient = -weighted.T @ (wrench_sp - wrench) + eps * u
    inputs = [u, effectiveness, tilts, v_air, rates, wrench_sp, weights, least_effort, lower, upper]
    names = ["effectiveness", "tilts", "v_air_body", "rates_body", "wrench_sp", "wrench_weights", "least_effort",
             "lower", "upper"]  # fmt: skip
    qp_function = ca.Function(
        "allocation_qp",
        inputs,
        [ca.densify(e) for e in (hessian, gradient, lower - u, upper - u, jacobian, wrench)],
        ["u_trim", *names],
        ["H", "g", "l_box", "u_box", "A", "W"],
    )
    stiffest = ca.mmax(ca.diag(hessian))
    gap = ca.mmax(ca.fabs(u - ca.fmin(ca.fmax(u - gradient / stiffest, lower), upper)))
    wrench_function = ca.Function(
        "allocation_wrench", inputs, [ca.densify(wrench), gap], ["u", *names], ["W", "optimality_gap"]
    )
    return qp_function, wrench_function
