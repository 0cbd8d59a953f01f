"""The full experiment set: `vtol scenario all --controller both`, timed (goal: at most 60 s on 2 cores).

    python benchmarks/bench_scenarios.py [--out DIR] [--no-record] [--jobs J] [--baseline DIR] [--repeats N]

Runs the command as a user would (a subprocess, default zenoh recording on, its default --jobs unless given),
then prints the total wall time against the 60-second goal, each run's simulated and wall seconds, its real-time
factor and the autopilot's lockstep holds (runs flown two at a time share the cores, so these factors are lower
than a run's alone), and the MPC's acceptance checks from the report. Then `vtol scenario accel` once per
controller, alone (--jobs 1), for the real-time factors asked of one run. The run folders and report stay in DIR
(default: a temporary folder, removed afterwards).

With `--baseline DIR` (a checkout of another commit, e.g. `git worktree add DIR main`) each command is timed
`--repeats` times (default 3) for this tree and for DIR's code, alternately, and the medians and this tree's ratio
to the baseline, round by round, are printed: the machine's noise meets both alike.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from baseline import ratio_summary, run_in
from bench_sitl import GOALS  # the same real-time factors are asked of `vtol scenario accel`

from ground_tools.scenario_report import acceptance, load_runs

GOAL_S = 60.0


def run_command(command: list[str], tree: Path | None) -> tuple[float, subprocess.CompletedProcess[str]]:
    """Wall seconds and the result of `command` with this tree's code, or with the checkout `tree`'s."""
    started = time.perf_counter()
    result = run_in(command, tree, capture_output=True)
    return time.perf_counter() - started, result


def against_baseline(args: argparse.Namespace, scratch: Path) -> None:
    """Each command timed alternately with this tree and the baseline's code, `args.repeats` rounds."""
    record = ["--no-record"] if args.no_record else []
    jobs = ["--jobs", str(args.jobs)] if args.jobs else []
    walls: dict[str, list[float]] = {"here": [], "there": []}
    alone: dict[str, dict[str, list[float]]] = {c: {"here": [], "there": []} for c in ("mpc", "pid")}
    for round_index in range(args.repeats):
        order = [("here", None), ("there", args.baseline)]
        for side, tree in order[::-1] if round_index % 2 else order:
            out = scratch / f"{side}-{round_index}"
            wall, result = run_command([sys.executable, "-m", "ground_tools", "scenario", "all", "--controller",
                                        "both", "--out", str(out), "--no-progress", *record, *jobs], tree)  # fmt: skip
            if result.returncode != 0:
                raise SystemExit(f"{side}: exit code {result.returncode}\n{result.stderr[-2000:]}")
            walls[side].append(wall)
            for controller in ("mpc", "pid"):
                folder = out / "alone"
                _, flown = run_command([sys.executable, "-m", "ground_tools", "scenario", "accel", "--controller",
                                        controller, "--jobs", "1", "--out", str(folder), "--no-progress", *record],
                                       tree)  # fmt: skip
                if flown.returncode != 0:
                    raise SystemExit(
                        f"{side}: accel {controller}: exit code {flown.returncode}\n{flown.stderr[-2000:]}"
                    )
                run = json.loads((folder / "accel" / controller / "run.json").read_text())
                alone[controller][side].append(run["sim_s"] / run["wall_s"])
    print(f"{args.repeats} rounds, baseline {args.baseline}, recording {'off' if args.no_record else 'on'}")
    print(ratio_summary("vtol scenario all --controller both, wall s", walls["here"], walls["there"], "lower"))
    for controller, sides in alone.items():
        print(ratio_summary(f"accel, {controller.upper()}, alone, x real time", sides["here"], sides["there"],
                            "higher"))  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", help="keep the runs here (default: a temporary folder)")
    parser.add_argument("--no-record", action="store_true", help="pass --no-record (no zenoh recording)")
    parser.add_argument("--jobs", type=int, help="pass --jobs J (default: the command's default)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the figures and metrics to FILE (JSON)")
    parser.add_argument("--baseline", type=Path, metavar="DIR", help="time against a checkout of another commit")
    parser.add_argument("--repeats", type=int, default=3, help="rounds against the baseline (default 3)")
    args = parser.parse_args()
    if args.baseline is not None:
        with tempfile.TemporaryDirectory() as scratch:
            against_baseline(args, Path(scratch))
        return 0
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(args.out) if args.out else Path(scratch)
        command = [sys.executable, "-m", "ground_tools", "scenario", "all", "--controller", "both", "--out", str(out),
                   "--no-progress", *(["--no-record"] if args.no_record else []),
                   *(["--jobs", str(args.jobs)] if args.jobs else [])]  # fmt: skip
        started = time.perf_counter()
        result = subprocess.run(command, capture_output=True, text=True)
        wall = time.perf_counter() - started
        jobs = f" --jobs {args.jobs}" if args.jobs else ""
        print(f"vtol scenario all --controller both{jobs}: {wall:.0f} s wall ({wall / 60:.1f} min; goal <= "
              f"{GOAL_S:.0f} s: {'met' if wall <= GOAL_S else 'NOT met'}), exit code {result.returncode}")  # fmt: skip
        if result.returncode != 0:
            print(result.stderr[-2000:])
        runs = load_runs(out)
        factors = []
        figures: dict[str, Any] = {"wall_s": wall, "jobs": args.jobs, "record": not args.no_record, "runs": {},
                                   "alone": {}, "checks": [], "pid_failed": []}  # fmt: skip
        print(f"{'scenario':15} {'ctrl':4} {'sim s':>6} {'wall s':>7} {'x real time':>11} {'holds':>6}")
        for name, by in runs.items():
            for controller, (_, run) in by.items():
                factor = run["sim_s"] / run["wall_s"]
                factors.append(factor)
                holds = run["processes"]["autopilot"].get("links", {}).get("lockstep_holds")
                figures["runs"].setdefault(name, {})[controller] = {
                    "sim_s": run["sim_s"], "wall_s": run["wall_s"], "real_time_factor": factor, "holds": holds,
                    "metrics": by[controller][0],
                }  # fmt: skip
                print(f"{name:15} {controller:4} {run['sim_s']:6.1f} {run['wall_s']:7.1f} {factor:11.1f} {holds:>6}")
        if factors:
            print(f"real-time factor: median {statistics.median(factors):.1f}x over {len(factors)} runs")
        for controller in ("mpc", "pid"):
            alone = Path(scratch) / "alone"
            accel = [sys.executable, "-m", "ground_tools", "scenario", "accel", "--controller", controller,
                     "--jobs", "1", "--out", str(alone), "--no-progress",
                     *(["--no-record"] if args.no_record else [])]  # fmt: skip
            flown = subprocess.run(accel, capture_output=True, text=True)
            if flown.returncode != 0:
                print(flown.stderr[-2000:])
                continue
            run = json.loads((alone / "accel" / controller / "run.json").read_text())
            recording = "off" if args.no_record else "on"
            figures["alone"][controller] = run["sim_s"] / run["wall_s"]
            print(f"accel, {controller.upper()}, alone, through MAVLink, recording {recording}: "
                  f"{run['sim_s'] / run['wall_s']:.1f}x real time (goal >= {GOALS[controller]:g}x)")  # fmt: skip
        for name, by in runs.items():
            if "mpc" in by:
                pid = by["pid"][0] if "pid" in by else None
                for text, passed in acceptance(name, by["mpc"][0], pid):
                    print(f"  {name}: MPC {text}: {'pass' if passed else 'FAIL'}")
                    figures["checks"].append({"scenario": name, "check": text, "passed": passed})
        failed_pid = [name for name, by in runs.items() if "pid" in by and not by["pid"][0]["survived"]]
        print(f"PID does not survive: {', '.join(failed_pid) or 'none'}")
        figures["pid_failed"] = failed_pid
        if args.json:
            args.json.write_text(json.dumps(figures, indent=1) + "\n")
        if args.out:
            print(f"report: {out / 'report.md'}")
        print(json.dumps({"wall_s": round(wall, 1), "runs": sum(len(by) for by in runs.values())}))
    return result.returncode


if __name__ == "__main__":
    sys.exit(main())
