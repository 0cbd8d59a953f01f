"""Control allocation speed: 5000 allocations along a slowly varying, closed-loop-like demand (docs/autopilot.md, 250 Hz).

    python benchmarks/bench_allocation.py [--solves 5000] [--no-compile]

The trajectory is a 20 s forward transition at 250 Hz: tilts 0 -> 90 deg, airspeed 0 -> 26 m/s, and a demand that
the model can meet (its wrench of a smooth actuator history with attitude-loop-like oscillations), with rotor 1
failed for the last fifth. Prints the median and p99 in microseconds of
  - allocate(): the whole call from Python (model evaluation, QP update and solve, clipping, result object);
  - the proxsuite solve alone: the same QP sequence replayed on an identical persistent solver, timing solve()
    (and update() + solve()) from Python, plus proxsuite's own C++ timer.
Goal: allocate() median <= 50 us (docs/figures.md).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time
from pathlib import Path

import casadi as ca
import numpy as np
import proxsuite

from aircraft.airframe import Airframe, load_airframe
from aircraft.wrench import actuator_wrench
from autopilot.control.allocation import ControlAllocator

RATE_HZ = 250.0


def reference_wrench_function(airframe: Airframe) -> ca.Function:
    """W(u; tilts, v_air_body, rates_body) straight from the shared model, to build feasible demands."""
    u, tilts, v_air, rates = ca.SX.sym("u", 8), ca.SX.sym("tilts", 4), ca.SX.sym("v", 3), ca.SX.sym("w", 3)
    wrench = actuator_wrench(airframe, u, tilts, v_air, rates)
    return ca.Function("reference_wrench", [u, tilts, v_air, rates], [wrench])


def trajectory(
    wrench: ca.Function, airframe: Airframe, step: int, total: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Demand, tilts, body airspeed and rates at one step of the transition.

    The demand is the model's wrench of a smooth reference actuator history (rotors from hover thrust down to
    cruise thrust, surfaces and rotor differentials oscillating like an attitude loop's output), so it is
    feasible while all actuators are healthy.
    """
    s = step / max(total - 1, 1)
    t = step / RATE_HZ
    hover = airframe.hover_thrust_per_rotor / airframe.thrust_max
    collective = hover + (0.12 - hover) * s
    roll, pitch, yaw = 0.03 * math.sin(2.1 * t), 0.03 * math.sin(1.7 * t + 0.5), 0.03 * math.sin(0.9 * t + 1.0)
    u_ref = np.array([
        collective - roll + pitch + yaw, collective - roll - pitch - yaw,
        collective + roll - pitch + yaw, collective + roll + pitch - yaw,
        0.2 * math.sin(2.1 * t), -0.2 * math.sin(2.1 * t), 0.1 * math.sin(1.7 * t), 0.3 * math.sin(0.9 * t),
    ])  # fmt: skip
    tilts = math.radians(90.0) * s + 0.01 * np.sin(t + np.arange(4))
    v_air = np.array([26.0 * s, 0.3 * math.sin(0.5 * t), 0.8 * s])
    rates = np.array([0.05 * math.sin(2.0 * t), 0.05 * math.cos(1.5 * t), 0.02 * math.sin(t)])
    wrench_sp = np.asarray(wrench(u_ref, tilts, v_air, rates)).ravel()
    return wrench_sp, tilts, v_air, rates


def percentile(samples: list[float], q: float) -> float:
    ordered = sorted(samples)
    return ordered[min(len(ordered) - 1, int(round(q / 100.0 * (len(ordered) - 1))))]


def summary(name: str, samples_s: list[float]) -> str:
    us = [x * 1e6 for x in samples_s]
    median, p99 = statistics.median(us), percentile(us, 99)
    return f"{name:44s} median {median:7.1f} us   p99 {p99:7.1f} us   max {max(us):7.1f} us"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--solves", type=int, default=5000)
    parser.add_argument("--no-compile", action="store_true", help="CasADi's VM instead of generated C")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the figures to FILE (JSON)")
    args = parser.parse_args()
    if args.solves < 10:
        parser.error("--solves must be at least 10")
    airframe = load_airframe()
    wrench = reference_wrench_function(airframe)
    inputs = [trajectory(wrench, airframe, k, args.solves) for k in range(args.solves)]
    failure_step = args.solves * 4 // 5
    hover = [airframe.hover_thrust_per_rotor / airframe.thrust_max] * 4 + [0.0] * 4

    def run(record: bool) -> tuple[list[float], list, list[int], int, list[float]]:
        """One pass over the trajectory with a fresh allocator; timing and recording in separate passes."""
        allocator = ControlAllocator(airframe, compile_model=not args.no_compile, u_initial=hover)
        times = [0.0] * args.solves
        recorded, iterations, residuals, fallbacks = [], [], [], 0
        for k, (wrench_sp, tilts, v_air, rates) in enumerate(inputs):
            if k == failure_step:
                allocator.set_failed(0)
            start = time.perf_counter()
            result = allocator.allocate(wrench_sp, tilts, v_air, rates)
            times[k] = time.perf_counter() - start
            if record:
                recorded.append((allocator._hessian.copy(order="F"), allocator._gradient.copy(),
                                 allocator._l_box.copy(), allocator._u_box.copy()))  # fmt: skip
                iterations.append(result.iterations)
                residuals.append(float(np.linalg.norm(result.residual)))
                fallbacks += result.fallback
        return times, recorded, iterations, fallbacks, residuals

    run(False)  # warm-up: caches, the compiled model's library
    total, _, _, _, _ = run(False)
    _, recorded, iterations, fallbacks, residuals = run(True)

    # The same QP sequence on an identical persistent solver: proxsuite alone.
    qp = ControlAllocator(airframe, compile_model=not args.no_compile, u_initial=hover)._new_solver()
    qp.settings.compute_timings = True
    solve_only, update_solve, internal = [], [], []
    for hessian, gradient, l_box, u_box in recorded:
        start = time.perf_counter()
        qp.update(hessian, gradient, None, None, None, None, None, l_box, u_box)
        middle = time.perf_counter()
        qp.solve()
        end = time.perf_counter()
        update_solve.append(end - start)
        solve_only.append(end - middle)
        internal.append(qp.results.info.solve_time * 1e-6)  # proxsuite reports microseconds

    healthy = residuals[:failure_step]
    print(f"{args.solves} allocations, proxsuite {proxsuite.__version__}, "
          f"model {'VM' if args.no_compile else 'generated C'}; rotor 1 fails at step {failure_step}")  # fmt: skip
    print(summary("allocate() including Python", total))
    print(summary("proxsuite update() + solve() from Python", update_solve))
    print(summary("proxsuite solve() from Python", solve_only))
    print(summary("proxsuite solve, its own timer", internal))
    print(f"{'iterations':44s} median {statistics.median(iterations):7.1f}      p99 {percentile(iterations, 99):7.1f}"
          f"      max {max(iterations)}; fallbacks {fallbacks}")  # fmt: skip
    print(f"{'|residual| healthy (feasible demand), N & N m':44s} median {statistics.median(healthy):7.1e}   "
          f"   max {max(healthy):7.1e}")  # fmt: skip
    print(f"{'|residual| after the rotor 1 failure':44s} median {statistics.median(residuals[failure_step:]):7.1e}   "
          f"   max {max(residuals[failure_step:]):7.1e}")  # fmt: skip
    goal = statistics.median(total) * 1e6 <= 50.0
    print(f"goal: allocate() median <= 50 us: {'met' if goal else 'NOT met'}")
    if args.json:
        figures = {"solves": args.solves, "allocate_us_median": statistics.median(total) * 1e6,
                   "allocate_us_p99": percentile(total, 99) * 1e6, "fallbacks": fallbacks}  # fmt: skip
        args.json.write_text(json.dumps(figures, indent=1) + "\n")


if __name__ == "__main__":
    main()
