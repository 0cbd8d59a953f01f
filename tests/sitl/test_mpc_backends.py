"""The MPC's two QP back-ends: HPIPM through its OCP-QP C interface (default) and CasADi's `conic` (fallback)."""

from __future__ import annotations

from autopilot.mpc.horizon import StageGrid
from autopilot.mpc.rti import QpBackend, RtiSolver
from tests.unit.test_mpc_backends import iterate


def test_without_a_compiler_the_mpc_says_so_and_solves_through_casadi(airframe, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("TILTROTOR_SITL_CACHE", str(tmp_path))  # nothing cached: it must compile
    monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    solver = RtiSolver(airframe, StageGrid.uniform(5))
    assert solver.backend is QpBackend.CASADI_CONIC
    assert "conic interface" in capsys.readouterr().err
    assert all(solution.ok for solution in iterate(solver, 2))
