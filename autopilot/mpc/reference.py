"""The MPC's NLP solved the paper's way, by IPOPT to convergence: the reference the real-time iteration is checked
against (tests/test_mpc.py's agreement test) and the benchmark's "paper's way" figures (docs/mpc.md, the solver)."""

from __future__ import annotations

import casadi as ca
import numpy as np

from autopilot.mpc.model import NP, NU, NX, P_STEP, PSI_D_INDEX, PSI_INDEX
from autopilot.mpc.rti import RtiSolver


class ReferenceNlp:
    """The same NLP solved the paper's way: IPOPT to convergence from a cold start, built once with the initial
    state and the stage parameters as NLP parameters (the paper rebuilt it at every call: solve_reference_nlp).

    Same dynamics, cost (sum of the squared residuals) and constraints as the RTI. Used by the agreement test and
    by the benchmark's "paper's way" figures.
    """

    def __init__(self, solver: RtiSolver, tol: float = 1e-10) -> None:
        n, stride = solver.horizon, NX + NU
        self.solver = solver
        w = ca.SX.sym("w", solver.n_w)
        x0, params = ca.SX.sym("x0", NX), ca.SX.sym("P", NP, n + 1)
        xs = [w[k * stride : k * stride + NX] for k in range(n + 1)]
        us = [w[k * stride + NX : (k + 1) * stride] for k in range(n)]
        model = solver.model
        cost = 0
        constraints = [xs[0] - x0]
        lbg, ubg = [0.0] * NX, [0.0] * NX
        for k in range(n):
            cost += ca.sumsqr(model.stage_residual(xs[k], us[k], params[:, k]))
            constraints.append(solver.step_function(xs[k], us[k], params[P_STEP, k]) - xs[k + 1])
            lbg += [0.0] * NX
            ubg += [0.0] * NX
            constraints.append(us[k][PSI_D_INDEX] - xs[k][PSI_INDEX])
            lbg.append(-solver.limits.yaw_sp_offset)
            ubg.append(solver.limits.yaw_sp_offset)
        cost += ca.sumsqr(model.terminal_residual(xs[n], params[:, n]))
        self.lbg, self.ubg = lbg, ubg
        self.nlp = ca.nlpsol(
            "paper_nlp", "ipopt",
            {"x": w, "p": ca.vertcat(x0, ca.vec(params)), "f": cost, "g": ca.vertcat(*constraints)},
            {"ipopt.print_level": 0, "print_time": False, "ipopt.tol": tol, "ipopt.max_iter": 500},
        )  # fmt: skip
        self._cost = self.nlp.get_function("nlp_f")

    def solve(self, x0: np.ndarray, params: np.ndarray) -> np.ndarray:
        """The optimal w from x0 and the stage parameters (NP, N+1), with the solver's current bounds."""
        solver, stride = self.solver, NX + NU
        cold = np.zeros(solver.n_w)
        for k in range(solver.horizon + 1):
            cold[k * stride : k * stride + NX] = x0
        result = self.nlp(x0=cold, p=self._parameters(x0, params), lbx=solver.lbw, ubx=solver.ubw, lbg=self.lbg,
                          ubg=self.ubg)  # fmt: skip
        if not self.nlp.stats()["success"]:
            raise RuntimeError(f"IPOPT did not converge: {self.nlp.stats()['return_status']}")
        return np.asarray(result["x"]).ravel()

    def cost(self, w: np.ndarray, x0: np.ndarray, params: np.ndarray) -> float:
        """The NLP's cost at w (from x0, the stage parameters (NP, N+1))."""
        return float(self._cost(x=w, p=self._parameters(x0, params))["f"])

    def _parameters(self, x0: np.ndarray, params: np.ndarray) -> np.ndarray:
        return np.concatenate((x0, self.solver.stage_parameters(params).ravel(order="F")))


def solve_reference_nlp(solver: RtiSolver, x0: np.ndarray, params: np.ndarray, tol: float = 1e-10) -> np.ndarray:
    """The paper's way to the letter: the NLP built afresh, then solved (ReferenceNlp); returns the optimal w."""
    return ReferenceNlp(solver, tol).solve(x0, params)
