"""`vtol scenario NAME|all [--controller mpc|pid|both] [--mpc-horizon paper|long]
[--out DIR] [--instance I] [--jobs J] [--no-record]`.

Flies each (scenario, controller) run with a progress bar, J at a time (ground_tools/scenario_flights.py; each run
its own lockstep plant and autopilot, so what a run flies does not depend on J), writes the run folders and the
figures with the controllers overlaid, prints the metrics, and for `all` writes `<out>/report.md`.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from autopilot.mpc.horizon import HORIZONS
from ground_tools.exit_status import CHECK_FAILED, FAILED, INTERRUPTED, OK, epilog
from ground_tools.scenario_flights import FlightQueue
from ground_tools.scenario_report import acceptance, write_report
from ground_tools.scenario_run import RunResult
from scenarios.experiments import SCENARIOS
from tiltrotor_sitl import Controller
from transport.cli import bounded_int, fail, positive_float, writable_folder
from transport.udp import usable_cpus

PROG = "vtol"
SHOWN = ("survived", "vx_rmse", "vz_max_abs", "pitch_max_abs_deg", "alt_change_max_m", "t_reach_s", "radial_rmse_m",
         "radial_max_m", "bank_mean_deg", "vx_rmse_after_failure", "solve_ms_median", "solves_failed")  # fmt: skip


EPILOG = epilog(ok="every run flown and every acceptance check passed",
                failed="a run failed to fly (its error on stderr)",
                check_failed="every run flew but an acceptance check printed FAIL")  # fmt: skip


def add_scenario_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = EPILOG
    parser.add_argument("name", choices=[*SCENARIOS, "all"], help="a paper experiment, or all five")
    parser.add_argument(
        "--controller",
        choices=("mpc", "pid", "both"),
        default="both",
        help="velocity controller(s) to fly (default both, overlaid in the figures)",
    )
    parser.add_argument("--mpc-horizon", choices=sorted(HORIZONS),
                        help="the MPC's horizon: paper (25 x 10 ms) or long (docs/design/alternatives.md, the long horizon); default: the "
                             "autopilot's VT_MPC_HRZN")  # fmt: skip
    parser.add_argument("--out", default="runs", metavar="DIR", help="output folder (default ./runs)")
    parser.add_argument(
        "--instance",
        type=bounded_int(0, 999),
        metavar="I",
        help="use instance I's ports (docs/plant-link.md), e.g. for `vtol watch --instance I`; default: free ports",
    )
    parser.add_argument("--jobs", type=bounded_int(1, 64), metavar="J",
                        help="runs flown at a time, each in a worker process (default: 2 on a machine with 2 or more "
                             "cores, else 1; 1 with --instance)")  # fmt: skip
    parser.add_argument(
        "--duration",
        type=positive_float,
        metavar="S",
        help="fly only the first S seconds of each profile (quick looks, tests; no acceptance checks)",
    )
    parser.add_argument("--no-record", action="store_true", help="no zenoh telemetry and no recording of it")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def default_jobs(instance: int | None) -> int:
    """Two runs at a time where there are two cores: a lockstep pair mostly alternates, so one run leaves a core
    partly idle (docs/figures.md); one with --instance, whose ports only one run can use."""
    return 1 if instance is not None else min(2, usable_cpus())


def scenario(args: argparse.Namespace) -> int:
    if args.jobs is not None and args.jobs > 1 and args.instance is not None:
        fail(f"{PROG} scenario", f"--instance gives one vehicle's ports; it cannot go with --jobs {args.jobs}")
    out = writable_folder(PROG, Path(args.out))
    names = list(SCENARIOS) if args.name == "all" else [args.name]
    controllers: list[Controller] = ["mpc", "pid"] if args.controller == "both" else [args.controller]
    flights = [(name, controller) for name in names for controller in controllers]
    jobs = min(len(flights), args.jobs or default_jobs(args.instance))
    if jobs > 1:  # the longest first, so that the last to end are short; each MPC run beside a PID run (stable sort)
        flights.sort(key=lambda flight: -SCENARIOS[flight[0]].duration_s)
    started = time.perf_counter()
    failed = []
    queue = FlightQueue(out, args, jobs)
    try:
        for (name, controller), result in queue.fly(flights):
            if not isinstance(result, RunResult):
                print(f"{PROG}: {name} with the {controller} failed: {result}", file=sys.stderr)
                failed.append(f"{name}/{controller}")
                continue
            shown = {key: result.metrics.get(key) for key in SHOWN if result.metrics.get(key) is not None}
            print(
                f"{PROG}: {name} ({controller}): {result.sim_s:g} s flown in {result.wall_s:.1f} s; "
                + ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in shown.items())
            )
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted: the runs in flight were stopped, their processes killed", file=sys.stderr)
        return INTERRUPTED
    checks_failed = []
    for name in names:
        figures = queue.figures.get(name)
        if figures:
            print(f"{PROG}: {name}: figures in {figures[0].parent.parent}/*/")
        if "mpc" in controllers and args.duration is None:
            checks_failed += checked(out, name)
    if args.name == "all":
        report = write_report(out, time.perf_counter() - started)
        print(f"{PROG}: report {report}")
    return exit_status(failed, checks_failed)


def checked(out: Path, name: str) -> list[str]:
    """Print the MPC's acceptance checks of scenario `name` from its run folders under `out` (pass or FAIL); the
    ones that failed."""
    mpc_metrics = out / name / "mpc" / "metrics.json"
    if not mpc_metrics.is_file():
        return []
    pid_path = out / name / "pid" / "metrics.json"
    pid = json.loads(pid_path.read_text()) if pid_path.is_file() else None
    failed = []
    for text, passed in acceptance(name, json.loads(mpc_metrics.read_text()), pid):
        print(f"{PROG}: {name}: MPC {text}: {'pass' if passed else 'FAIL'}")
        if not passed:
            failed.append(f"{name}: {text}")
    return failed


def exit_status(failed_runs: list[str], failed_checks: list[str]) -> int:
    """FAILED when a run failed to fly, else CHECK_FAILED when an acceptance check failed, else OK; says why."""
    if failed_runs:
        print(f"{PROG}: error: {len(failed_runs)} run(s) failed: {', '.join(failed_runs)}", file=sys.stderr)
        return FAILED
    if failed_checks:
        print(f"{PROG}: error: {len(failed_checks)} acceptance check(s) failed: {'; '.join(failed_checks)}",
              file=sys.stderr)  # fmt: skip
        return CHECK_FAILED
    return OK
