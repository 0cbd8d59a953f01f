"""MPC solve times in closed loop (acceleration profile), against the same NLP solved the paper's way.

    python benchmarks/bench_mpc.py [--seconds 25] [--ipopt-samples 20] [--horizons 10,25,50,100]

The closed loop runs in one process (plant physics + the autopilot's flight controller, no sockets), so the
figures are the MPC's own: one RTI per 100 Hz tick (compiled QP data + HPIPM), including Python. The paper's
way is IPOPT on the same NLP, built afresh and solved cold to convergence, timed on states of the same run.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from aircraft.airframe import load_airframe
from autopilot.controllers import MPC, build_flight_controller
from autopilot.mpc import solve_reference_nlp
from autopilot.vehicle_state import VehicleState, euler_from_quaternion
from scenarios.profiles import accel
from sim_bridge.plant import Plant, Spawn


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


def closed_loop(seconds: float, horizon: int = 25, ipopt_every: int = 0):
    """Fly the acceleration profile; returns (controller, IPOPT times, max deviation RTI vs IPOPT first input)."""
    airframe = load_airframe()
    plant = Plant(airframe, Spawn(altitude=100.0))
    controller = build_flight_controller(airframe, MPC, mpc_horizon=horizon)
    state = VehicleState()
    ipopt_times = []
    solves_seen = 0
    for _ in range(int(seconds * 400)):
        vehicle_state(plant, state)
        if controller.velocity_due(state.time_usec):
            controller.set_velocity_setpoint(accel(state.time_s))
        controller.step(state)
        mpc = controller.mpc
        if ipopt_every and len(mpc.solve_times_s) > solves_seen:
            solves_seen = len(mpc.solve_times_s)
            if solves_seen % ipopt_every == 0:
                started = time.perf_counter()
                solve_reference_nlp(mpc.solver, mpc.last_x0, mpc.params, tol=1e-8)
                ipopt_times.append(time.perf_counter() - started)
        plant.set_command(controller.command)
        plant.step()
    return controller, ipopt_times


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=25.0)
    parser.add_argument("--ipopt-samples", type=int, default=20)
    parser.add_argument("--horizons", default="10,25,50,100")
    parser.add_argument("--scaling-seconds", type=float, default=4.0)
    args = parser.parse_args()
    solves = int(args.seconds * 100)
    controller, ipopt = closed_loop(args.seconds, ipopt_every=max(1, solves // max(args.ipopt_samples, 1)))
    times_ms = [t * 1e3 for t in controller.mpc.solve_times_s]
    median = statistics.median(times_ms)
    print(f"acceleration profile, {args.seconds:g} s closed loop, N = 25, dt = 0.01 s: {len(times_ms)} solves, "
          f"{controller.mpc.solves_failed} failed, fell back to PID: {controller.fell_back_to_pid}")  # fmt: skip
    print(f"RTI (compiled QP data + HPIPM)   median {median:6.2f} ms   p99 {percentile(times_ms, 99):6.2f} ms   "
          f"max {max(times_ms):6.2f} ms   (goal: median <= 1 ms, p99 <= 3 ms; budget 10 ms)")  # fmt: skip
    if ipopt:
        ipopt_ms = [t * 1e3 for t in ipopt]
        print(f"paper's way (IPOPT, rebuilt, cold) median {statistics.median(ipopt_ms):6.1f} ms   "
              f"max {max(ipopt_ms):6.1f} ms over {len(ipopt_ms)} states of the same run")  # fmt: skip
        print(f"ratio of medians                 {statistics.median(ipopt_ms) / median:6.0f}x")
    print("horizon scaling (closed loop, first seconds of the profile):")
    for horizon in (int(h) for h in args.horizons.split(",")):
        scaled, _ = closed_loop(args.scaling_seconds, horizon=horizon)
        values = [t * 1e3 for t in scaled.mpc.solve_times_s]
        print(f"  N = {horizon:3d}: median {statistics.median(values):6.2f} ms, p99 {percentile(values, 99):6.2f} ms, "
              f"{scaled.mpc.solves_failed} failed")  # fmt: skip


if __name__ == "__main__":
    main()
