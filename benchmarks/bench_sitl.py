"""Whole SITL speed: vtol-sim + vtol-autopilot in lockstep flying a paper profile, simulated s per wall s.

    python benchmarks/bench_sitl.py [--profile accel] [--repeats 3]

Prints the median real-time factor over the repeats, and each process's own work per physics step
(the rest of the wall time is the two processes waiting for each other's datagrams).
"""

from __future__ import annotations

import argparse
import statistics

from ground_tools.lockstep_flight import fly_lockstep
from scenarios.profiles import PROFILES

GOALS = {"pid": 25.0, "mpc": 10.0}  # real-time factors asked for the whole SITL (docs/performance.md)


def run_once(profile: str, duration: float, controller: str) -> dict[str, float]:
    flight = fly_lockstep(profile, duration, controller=controller)
    ap, pl = flight.autopilot, flight.plant
    return {
        "real_time_factor": pl["real_time_factor"],
        "plant_us_per_step": pl["busy_time_s"] / pl["steps"] * 1e6,
        "autopilot_us_per_step": ap["busy_us_per_step"],
        "wall_us_per_step": pl["wall_time_s"] / pl["steps"] * 1e6,
        "missed": pl["missed_commands"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--profile", choices=sorted(PROFILES), default="accel")
    parser.add_argument("--duration", type=float, help="simulated seconds (default: the profile's)")
    parser.add_argument("--controller", default="pid")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    duration = args.duration or PROFILES[args.profile][1]
    runs = [run_once(args.profile, duration, args.controller) for _ in range(args.repeats)]

    def median(key: str) -> float:
        return statistics.median(run[key] for run in runs)

    factors = [run["real_time_factor"] for run in runs]
    print(f"profile {args.profile}, {duration:g} s simulated, {args.controller} controller, lockstep, "
          f"{args.repeats} runs")  # fmt: skip
    goal = GOALS.get(args.controller)
    print(f"real-time factor          median {median('real_time_factor'):.1f}x (min {min(factors):.1f}, "
          f"max {max(factors):.1f})" + (f"; goal >= {goal:g}x with the {args.controller.upper()}" if goal else ""))
    print(f"wall time per step        median {median('wall_us_per_step'):.0f} us")
    print(f"autopilot work per step   median {median('autopilot_us_per_step'):.0f} us")
    print(f"plant work per step       median {median('plant_us_per_step'):.0f} us")
    print(f"missed commands           {sum(run['missed'] for run in runs)}")


if __name__ == "__main__":
    main()
