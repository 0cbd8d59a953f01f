"""What the ULog logger costs the control loop: a paper profile flown in lockstep with the logger and without it
(`--no-ulog`), alternated round by round so that a machine whose speed drifts meets both alike.

    python benchmarks/bench_ulog.py [--profile accel] [--rounds 5] [--controller mpc|pid]

Prints each run's wall time and the autopilot's own work per plant step (busy_us_per_step), their medians, and the
log's size. Each flight is spawned hovering (armed: SDLOG_MODE 0 logs from the first step to the last).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from pathlib import Path

from ground_tools.lockstep_flight import fly_lockstep
from scenarios.profiles import PROFILES


def run_once(profile: str, duration: float, controller: str, folder: Path, logging: bool) -> dict[str, float]:
    args = ("--params", str(folder / "params.json"), "--root", str(folder / "root"))
    flight = fly_lockstep(profile, duration, controller=controller, autopilot_args=args + (() if logging else
                          ("--no-ulog",)))  # fmt: skip
    logs = sorted((folder / "root" / "log").glob("*/*.ulg"))
    return {
        "wall_s": flight.autopilot["wall_time_s"],
        "busy_us_per_step": flight.autopilot["busy_us_per_step"],
        "log_bytes": logs[-1].stat().st_size if logging and logs else 0,
        "sim_s": flight.autopilot["sim_time_s"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--profile", choices=sorted(PROFILES), default="accel")
    parser.add_argument("--duration", type=float, help="simulated seconds (default: the profile's)")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--controller", choices=("mpc", "pid"), default="mpc")
    args = parser.parse_args()
    duration = args.duration or PROFILES[args.profile][1]
    results: dict[bool, list[dict[str, float]]] = {True: [], False: []}
    with tempfile.TemporaryDirectory(prefix="bench-ulog-") as scratch:
        for round_ in range(args.rounds):
            order = (True, False) if round_ % 2 == 0 else (False, True)
            for logging in order:
                folder = Path(scratch) / f"{round_}-{'log' if logging else 'nolog'}"
                folder.mkdir()
                result = run_once(args.profile, duration, args.controller, folder, logging)
                results[logging].append(result)
                print(f"round {round_ + 1} {'with' if logging else 'without'} the logger: {result['wall_s']:.2f} s wall "
                      f"for {result['sim_s']:.1f} s, autopilot {result['busy_us_per_step']:.0f} us/step"
                      + (f", log {result['log_bytes'] / 1e6:.2f} MB" if logging else ""), flush=True)  # fmt: skip
    for key, unit in (("wall_s", "s"), ("busy_us_per_step", "us/step")):
        with_log = statistics.median(r[key] for r in results[True])
        without = statistics.median(r[key] for r in results[False])
        print(
            f"median {key}: with {with_log:.2f} {unit}, without {without:.2f} {unit}, "
            f"difference {with_log - without:+.2f} {unit} ({(with_log / without - 1) * 100:+.1f} %)"
        )


if __name__ == "__main__":
    main()
