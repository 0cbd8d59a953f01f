"""Whole SITL speed: vtol-sim + vtol-autopilot in lockstep flying a paper profile, simulated s per wall s.

    python benchmarks/bench_sitl.py [--profile accel] [--repeats 3] [--controller both|mpc|pid] [--baseline DIR]

Prints, for the PID and for the MPC (solving one tick ahead, VT_MPC_OVERLAP = 1, and the paper's synchronous
way, 0), the median real-time factor over the repeats against its goal, and each process's own work per physics
step (the rest of the wall time is the two processes waiting for each other's datagrams); and the MPC's two ways
against each other, round by round. A round flies every configuration once, so a machine whose speed drifts
meets each of them alike.

With `--baseline DIR` (a checkout of another commit, e.g. `git worktree add DIR main`), every round also flies
each configuration with DIR's code (this interpreter, DIR first on the path), in alternating order, and prints
both medians and this tree's factor over the baseline's, round by round: the machine's noise meets both alike.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from baseline import run_in

from autopilot.storage.parameters import ParameterStore
from ground_tools.lockstep_flight import fly_lockstep
from scenarios.profiles import PROFILES

GOALS = {"pid": 25.0, "mpc": 10.0}  # real-time factors asked for the whole SITL (docs/figures.md)


def run_once(profile: str, duration: float, controller: str, params: Path) -> dict[str, float]:
    flight = fly_lockstep(profile, duration, controller=controller, autopilot_args=("--params", str(params)))
    ap, pl = flight.autopilot, flight.plant
    return {
        "real_time_factor": pl["real_time_factor"],
        "plant_us_per_step": pl["busy_time_s"] / pl["steps"] * 1e6,
        "autopilot_us_per_step": ap["busy_us_per_step"],
        "wall_us_per_step": pl["wall_time_s"] / pl["steps"] * 1e6,
        "missed": pl["missed_commands"],
    }


OVERLAPPED, SYNCHRONOUS = "mpc, overlapped (VT_MPC_OVERLAP 1)", "mpc, synchronous (VT_MPC_OVERLAP 0)"


def variants(controller: str) -> list[tuple[str, str, int]]:
    """(label, controller, VT_MPC_OVERLAP) of each configuration to fly."""
    mpc = [(OVERLAPPED, "mpc", 1), (SYNCHRONOUS, "mpc", 0)]
    pid = [("pid", "pid", 1)]
    return {"both": pid + mpc, "mpc": mpc, "pid": pid}[controller]


def run_baseline(
    directory: Path, profile: str, duration: float, controller: str, overlap: int, scratch: Path
) -> dict[str, float]:
    """One flight of `controller` with the code of the checkout `directory` (its own bench_sitl.py, one repeat)."""
    out = scratch / "baseline.json"
    command = [sys.executable, "benchmarks/bench_sitl.py", "--profile", profile, "--duration", str(duration),
               "--controller", controller, "--repeats", "1", "--json", str(out)]  # fmt: skip
    run_in(command, directory, check=True, stdout=subprocess.DEVNULL)
    label = {"pid": "pid", 0: SYNCHRONOUS, 1: OVERLAPPED}[overlap if controller == "mpc" else controller]
    return json.loads(out.read_text())["configurations"][label]


def overlap_params(path: Path, overlap: int) -> Path:
    """A parameter file for the autopilot with VT_MPC_OVERLAP = `overlap` (absent: all defaults, as 0 is)."""
    store = ParameterStore(path)
    store.set("VT_MPC_OVERLAP", overlap)
    if (error := store.flush()) is not None:
        raise SystemExit(f"cannot write {path}: {error}")
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--profile", choices=sorted(PROFILES), default="accel")
    parser.add_argument("--duration", type=float, help="simulated seconds (default: the profile's)")
    parser.add_argument("--controller", choices=("both", "mpc", "pid"), default="both")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the figures to FILE (JSON)")
    parser.add_argument("--baseline", type=Path, metavar="DIR", help="also fly a checkout of another commit")
    args = parser.parse_args()
    duration = args.duration or PROFILES[args.profile][1]
    print(f"profile {args.profile}, {duration:g} s simulated, lockstep, {args.repeats} runs each")
    configurations = variants(args.controller)
    runs: dict[str, list[dict[str, float]]] = {label: [] for label, _, _ in configurations}
    baseline: dict[str, list[dict[str, float]]] = {label: [] for label, _, _ in configurations}
    with tempfile.TemporaryDirectory() as scratch:
        params = {overlap: overlap_params(Path(scratch) / f"params-{overlap}.json", overlap)
                  for _, _, overlap in configurations}  # fmt: skip
        for round_index in range(args.repeats):
            for label, controller, overlap in configurations:
                flights = [lambda: runs[label].append(run_once(args.profile, duration, controller, params[overlap]))]
                if args.baseline is not None:
                    flights.append(
                        lambda: baseline[label].append(
                            run_baseline(args.baseline, args.profile, duration, controller, overlap, Path(scratch))
                        )
                    )
                    flights = flights[::-1] if round_index % 2 else flights  # alternate which flies first
                for fly in flights:
                    fly()
    for label, controller, _ in configurations:
        report(label, GOALS[controller], runs[label])
        if args.baseline is not None:
            report(f"{label}, baseline {args.baseline}", GOALS[controller], baseline[label])
            compare(runs[label], baseline[label])
    if args.json:
        medians = {label: {key: statistics.median(run[key] for run in runs[label]) for key in runs[label][0]}
                   for label in runs}  # fmt: skip
        args.json.write_text(json.dumps({"profile": args.profile, "seconds": duration, "repeats": args.repeats,
                                         "configurations": medians}, indent=1) + "\n")  # fmt: skip
    if OVERLAPPED in runs and SYNCHRONOUS in runs:
        ratios = [a["real_time_factor"] / b["real_time_factor"] for a, b in zip(runs[OVERLAPPED], runs[SYNCHRONOUS])]
        print(f"mpc, overlapped / synchronous, round by round: median {statistics.median(ratios):.2f} "
              f"(min {min(ratios):.2f}, max {max(ratios):.2f})")  # fmt: skip


def compare(runs: list[dict[str, float]], baseline: list[dict[str, float]]) -> None:
    """This tree against the baseline, round by round (each ratio from flights of the same round)."""
    for key, better in (("real_time_factor", "higher"), ("autopilot_us_per_step", "lower"),
                        ("plant_us_per_step", "lower")):  # fmt: skip
        ratios = [run[key] / base[key] for run, base in zip(runs, baseline)]
        print(f"  this / baseline, {key:22} median {statistics.median(ratios):.3f} (min {min(ratios):.3f}, "
              f"max {max(ratios):.3f}; {better} is better)")  # fmt: skip


def report(label: str, goal: float, runs: list[dict[str, float]]) -> None:
    def median(key: str) -> float:
        return statistics.median(run[key] for run in runs)

    factors = [run["real_time_factor"] for run in runs]
    print(f"{label}:")
    print(f"  real-time factor          median {median('real_time_factor'):.1f}x (min {min(factors):.1f}, "
          f"max {max(factors):.1f}); goal >= {goal:g}x")  # fmt: skip
    print(f"  wall time per step        median {median('wall_us_per_step'):.0f} us")
    print(f"  autopilot work per step   median {median('autopilot_us_per_step'):.0f} us")
    print(f"  plant work per step       median {median('plant_us_per_step'):.0f} us")
    print(f"  missed commands           {sum(run['missed'] for run in runs)}")


if __name__ == "__main__":
    main()
