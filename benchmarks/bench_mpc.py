"""MPC solve times in closed loop (acceleration profile), against the same NLP solved the paper's way.

    python benchmarks/bench_mpc.py [--seconds 25] [--ipopt-samples 20] [--horizons 10,25,50,100] [--levers]

The paper's horizon (25 x 10 ms) and the long one (docs/design/alternatives.md, the long horizon) fly the same profile, each timed.

The closed loop runs in one process (plant physics + the autopilot's flight controller, no sockets), so the
figures are the MPC's own: one RTI per 100 Hz tick, including Python. The paper's way is IPOPT on the same NLP,
solved cold to convergence on states of the same run: built once (NLP parameters x0 and P), and rebuilt at every
call as the paper did. --levers replays the run's states (x0 and stage parameters, in order) through solvers
built with each QP back-end and HPIPM setting, so every variant solves the same sequence of problems.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aircraft.airframe import load_airframe
from autopilot.controllers import MPC, build_flight_controller
from autopilot.mpc.controller import LEVENBERG, WARM_UP_ITERATIONS
from autopilot.mpc.horizon import LONG, PAPER, MpcHorizon, StageGrid
from autopilot.mpc.hpipm import HpipmMode, HpipmSettings
from autopilot.mpc.model import THRUST
from autopilot.mpc.reference import ReferenceNlp, solve_reference_nlp
from autopilot.mpc.rti import QpBackend, RtiSolver
from autopilot.topics.vehicle_state import VehicleState, euler_from_quaternion
from scenarios.profiles import accel
from sim_bridge.plant import Plant, Spawn

DEFAULT = HpipmSettings.for_tolerance(1e-5)
LEVERS: list[tuple[str, dict]] = [
    ("CasADi conic + compiled QP data (before)", {"backend": QpBackend.CASADI_CONIC}),
    ("C driver, HPIPM speed_abs, warm primal (default)", {}),
    ("  barrier from the mode's mu0 (10) every solve", {"hpipm": DEFAULT.but(mu0_warm=None)}),
    ("  barrier from 1e-4 after an easy solve", {"hpipm": DEFAULT.but(mu0_warm=1e-4)}),
    ("  barrier from 1e-3 every solve, cold ones too", {"hpipm": DEFAULT.but(mu0=1e-3, mu0_warm=None)}),
    ("  cold start", {"hpipm": DEFAULT.but(warm_start=0)}),
    ("  warm start, primal and dual", {"hpipm": DEFAULT.but(warm_start=2)}),
    ("  stopping on the duality measure only", {"hpipm": DEFAULT.but(residual_exit=False)}),
    ("  cold, stopping on the duality measure only", {"hpipm": DEFAULT.but(residual_exit=False, warm_start=0)}),
    ("  mode speed", {"hpipm": DEFAULT.but(mode=HpipmMode.SPEED)}),
    ("  classical Riccati (not square root)", {"hpipm": DEFAULT.but(ric_alg=0)}),
    ("  no predictor-corrector", {"hpipm": DEFAULT.but(pred_corr=0)}),
    ("  tolerance 1e-4 (feasibility 1e-6)", {"hpipm": HpipmSettings.for_tolerance(1e-4)}),
]


def vehicle_state(plant: Plant, state: VehicleState) -> VehicleState:
    x = plant.state
    state.time_usec = plant.time_usec
    state.position_ned[:] = x[0:3]
    state.velocity_ned[:] = x[3:6]
    state.quaternion[:] = x[6:10]
    state.euler[:] = euler_from_quaternion(*x[6:10].tolist())
    state.body_rates[:] = x[10:13]
    state.airspeed = float(plant.airspeed[0])
    state.valid = True
    return state


@dataclass
class Record:
    x0: np.ndarray
    params: np.ndarray


def closed_loop(seconds: float, horizon: MpcHorizon = PAPER):
    """Fly the acceleration profile; returns the controller, the MPC's (x0, parameters) of every solve and every
    solve's time (ms)."""
    airframe = load_airframe()
    plant = Plant(airframe, Spawn(altitude=100.0))
    controller = build_flight_controller(airframe, MPC, mpc_horizon=horizon)
    state = VehicleState()
    records: list[Record] = []
    times_ms: list[float] = []
    for _ in range(int(seconds * 400)):
        vehicle_state(plant, state)
        if controller.velocity_due(state.time_usec):
            controller.set_velocity_setpoint(accel(state.time_s))
        controller.step(state)
        mpc = controller.mpc
        if mpc.solve_times.count > len(records):
            records.append(Record(mpc.last_x0.copy(), mpc.params.copy()))
            times_ms.append(mpc.solve_times.last_s * 1e3)
        plant.set_command(controller.command)
        plant.step()
    return controller, records, times_ms


def replay(solver: RtiSolver, records: list[Record]) -> dict:
    """The controller's solve sequence on recorded states: shift, solve (thrust limits nominal)."""
    airframe = solver.airframe
    solver.set_actuator_limits(np.full(4, airframe.thrust_planned_max), np.full(4, np.nan))
    solver.levenberg = LEVENBERG
    solver.initialise(records[0].x0, airframe.hover_thrust_per_rotor)
    for _ in range(WARM_UP_ITERATIONS):
        solver.solve(records[0].x0, records[0].params)
    times, iterations, first_inputs, failed, qp_data, ipm = [], [], [], 0, [], []
    for k, record in enumerate(records):
        if k:
            solver.shift()
        solution = solver.solve(record.x0, record.params)
        times.append(solution.solve_time_s * 1e3)
        iterations.append(solution.iterations)
        first_inputs.append(solution.u[0].copy())
        failed += not solution.ok
        if solver.last_step is not None:
            qp_data.append(solver.last_step.qp_data_s * 1e3)
            ipm.append(solver.last_step.ipm_s * 1e3)
    return {"ms": times, "iterations": iterations, "u0": np.array(first_inputs), "failed": failed,
            "qp_data_ms": qp_data, "ipm_ms": ipm}  # fmt: skip


def spread(values: list[float]) -> str:
    return (f"median {statistics.median(values):6.3f} ms   p99 {float(np.percentile(values, 99)):6.3f} ms   "
            f"max {max(values):6.3f} ms")  # fmt: skip


def levers(records: list[Record]) -> None:
    airframe = load_airframe()
    print(f"levers: the same {len(records)} states replayed through each solver (max |u0 - default| in the "
          f"plan's units; thrust in N):")  # fmt: skip
    reference = None
    for name, options in LEVERS:
        result = replay(RtiSolver(airframe, **options), records)
        if options == {}:
            reference = result["u0"]
        deviation = "" if reference is None else f"   |du0| {np.abs(result['u0'] - reference).max():.1e}"
        thrust = "" if reference is None else f" (thrust {np.abs(result['u0'] - reference)[:, THRUST].max():.1e})"
        inside = ""
        if result["ipm_ms"]:
            inside = (f"   (QP data {statistics.median(result['qp_data_ms']):.3f}, "
                      f"HPIPM {statistics.median(result['ipm_ms']):.3f})")  # fmt: skip
        print(f"  {name:44s} {spread(result['ms'])}{inside}   {statistics.mean(result['iterations']):4.2f} iterations"
              f"{deviation}{thrust}   {result['failed']} failed")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=25.0)
    parser.add_argument("--ipopt-samples", type=int, default=20)
    parser.add_argument("--horizons", default="10,25,50,100")
    parser.add_argument("--scaling-seconds", type=float, default=4.0)
    parser.add_argument("--levers", action="store_true", help="replay the run through each solver variant")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the figures to FILE (JSON)")
    args = parser.parse_args()
    controller, records, times_ms = closed_loop(args.seconds)
    mpc = controller.mpc
    median = statistics.median(times_ms)
    print(f"acceleration profile, {args.seconds:g} s closed loop, N = 25, dt = 0.01 s: {len(times_ms)} solves, "
          f"{mpc.solves_failed} failed, fell back to PID: {controller.fell_back_to_pid}, back-end "
          f"{mpc.solver.backend.value}")  # fmt: skip
    print(f"RTI, the paper's horizon (N = 25 x 0.01 s)   {spread(times_ms)}   (goal: median <= 0.5 ms, p99 <= 1 ms)")
    figures: dict[str, float | int] = {"seconds": args.seconds, "solves": len(times_ms),
                                       "solves_failed": mpc.solves_failed, "rti_ms_median": median,
                                       "rti_ms_p99": float(np.percentile(times_ms, 99)), "rti_ms_max": max(times_ms)}  # fmt: skip
    samples = records[:: max(1, len(records) // max(args.ipopt_samples, 1))][: args.ipopt_samples]
    if samples:
        reference = ReferenceNlp(mpc.solver, tol=1e-8)
        built_once, rebuilt = [], []
        for record in samples:
            started = time.perf_counter()
            reference.solve(record.x0, record.params)
            built_once.append((time.perf_counter() - started) * 1e3)
        for record in samples[:3]:
            started = time.perf_counter()
            solve_reference_nlp(mpc.solver, record.x0, record.params, tol=1e-8)
            rebuilt.append((time.perf_counter() - started) * 1e3)
        once = statistics.median(built_once)
        figures |= {"ipopt_built_once_ms_median": once, "ipopt_rebuilt_ms_median": statistics.median(rebuilt)}
        print(f"IPOPT converged, NLP built once, cold start  median {once:7.1f} ms   max {max(built_once):7.1f} ms "
              f"over {len(built_once)} states of the run; ratio of medians {once / median:5.0f}x")  # fmt: skip
        again = statistics.median(rebuilt)
        print(f"IPOPT, NLP rebuilt every call (the paper)    median {again:7.1f} ms over {len(rebuilt)} states; "
              f"ratio {again / median:5.0f}x")  # fmt: skip
    long_controller, _, long_ms = closed_loop(args.seconds, LONG)
    grid = LONG.grid
    print(f"RTI, the long horizon ({grid.stages} stages, {grid.span_s:g} s, {LONG.gauss_newton_steps} QPs per tick) "
          f"{spread(long_ms)}   {long_controller.mpc.solves_failed} failed; ratio of medians "
          f"{statistics.median(long_ms) / median:4.2f}x")  # fmt: skip
    figures |= {"long_ms_median": statistics.median(long_ms), "long_solves_failed": long_controller.mpc.solves_failed}
    if args.json:
        args.json.write_text(json.dumps(figures, indent=1) + "\n")
    if args.levers:
        levers(records)
    if args.horizons:
        print("horizon scaling (closed loop, first seconds of the profile):")
    for horizon in (int(h) for h in args.horizons.split(",") if h):
        scaled, _, values = closed_loop(args.scaling_seconds, MpcHorizon(f"N = {horizon}", StageGrid.uniform(horizon)))
        print(f"  N = {horizon:3d}: {spread(values)}, {scaled.mpc.solves_failed} failed")


if __name__ == "__main__":
    main()
