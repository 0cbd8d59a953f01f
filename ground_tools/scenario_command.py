"""`vtol scenario NAME|all [--controller mpc|pid|both] [--mpc-horizon paper|long]
[--out DIR] [--instance I] [--jobs J] [--no-record]`.

Flies each (scenario, controller) run with a progress bar, J at a time in worker processes (each run is its own
lockstep plant and autopilot, so the runs do not depend on each other or on J), writes the run folders and the
figures with the controllers overlaid, prints the metrics, and for `all` writes `<out>/report.md`.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import multiprocessing
import os
import shutil
import signal
import sys
import time
from collections import Counter
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import replace
from pathlib import Path

from tqdm import tqdm

from autopilot.mpc_horizon import HORIZONS
from ground_tools.lockstep_client import START_MS, ScenarioError
from ground_tools.lockstep_flight import FlightFailed
from ground_tools.processes import Controller
from ground_tools.scenario_figures import plot_scenario
from ground_tools.scenario_report import acceptance, write_report
from ground_tools.scenario_run import RunResult, run_scenario
from scenarios.experiments import SCENARIOS, Scenario
from transport.cli import bounded_int, positive_float, writable_folder
from transport.flight_log import FlightLog, read_flight_log

PROG = "vtol"
SHOWN = ("survived", "vx_rmse", "vz_max_abs", "pitch_max_abs_deg", "alt_change_max_m", "t_reach_s", "radial_rmse_m",
         "radial_max_m", "bank_mean_deg", "vx_rmse_after_failure", "solve_ms_median", "solves_failed")  # fmt: skip


def add_scenario_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("name", choices=[*SCENARIOS, "all"], help="a paper experiment, or all five")
    parser.add_argument("--controller", choices=("mpc", "pid", "both"), default="both",
                        help="velocity controller(s) to fly (default both, overlaid in the figures)")
    parser.add_argument("--mpc-horizon", choices=sorted(HORIZONS),
                        help="the MPC's horizon: paper (25 x 10 ms) or long (docs/mpc.md 2.9); default: the "
                             "autopilot's VT_MPC_HRZN")  # fmt: skip
    parser.add_argument("--out", default="runs", metavar="DIR", help="output folder (default ./runs)")
    parser.add_argument("--instance", type=bounded_int(0, 999), metavar="I",
                        help="use instance I's ports (docs/plant-link.md), e.g. for `vtol watch --instance I`; default: free ports")
    parser.add_argument("--jobs", type=bounded_int(1, 64), metavar="J",
                        help="runs flown at a time, each in a worker process (default: 2 on a machine with 2 or more "
                             "cores, else 1; 1 with --instance)")  # fmt: skip
    parser.add_argument("--duration", type=positive_float, metavar="S",
                        help="fly only the first S seconds of each profile (quick looks, tests; no acceptance checks)")
    parser.add_argument("--no-record", action="store_true", help="no zenoh telemetry and no recording of it")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def refresh_figures(scenario: Scenario, out: Path) -> list[Path]:
    """The scenario's figures, every finished controller overlaid, written into each of its run folders."""
    runs: dict[str, FlightLog] = {}
    failures: dict[str, float | None] = {}
    folders: list[Path] = []
    for controller in ("mpc", "pid"):
        folder = out / scenario.name / controller
        if (folder / "timeseries.csv").is_file() and (folder / "run.json").is_file():
            runs[controller] = read_flight_log(folder / "timeseries.csv")
            failure = json.loads((folder / "run.json").read_text()).get("failure")
            failures[controller] = failure["t_s"] if failure else None
            folders.append(folder)
    if not folders:
        return []
    drawn = plot_scenario(scenario, runs, failures, folders[0])
    for folder in folders[1:]:  # the same figures: drawn once (a scenario's take 1-2 s), copied
        for figure in drawn:
            shutil.copyfile(figure, folder / figure.name)
    return drawn + [folder / figure.name for folder in folders[1:] for figure in drawn]


def _fly(scenario: Scenario, controller: Controller, out: Path, args: argparse.Namespace, bar_position: int = 0):
    total = START_MS / 1000.0 + scenario.duration_s
    bar = tqdm(total=round(total, 2), desc=f"{scenario.name} ({controller})", unit="sim s", leave=True,
               disable=True if args.no_progress else None, file=sys.stderr, position=bar_position,
               bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining}]")
    try:
        return run_scenario(scenario, controller, out, instance=args.instance, record=not args.no_record,
                            mpc_horizon=args.mpc_horizon,
                            on_progress=lambda sim_s: bar.update(round(min(sim_s, total) - bar.n, 2)))
    finally:
        bar.close()


_worker_bar_position = 0  # a worker process's progress-bar line, set once per worker


PR_SET_PDEATHSIG = 1  # Linux prctl(2)


_worker_stopped = False  # a worker's: Ctrl-C, or the command's process has ended
_worker_parent = 0  # a worker's: the command's process id


def _stop_worker(signum: int, frame: object) -> None:
    """The run in flight stops as on Ctrl-C (its plant and autopilot killed), and no further run starts: the pool's
    worker loop catches the interrupt as a task's outcome and would otherwise take the next run queued."""
    global _worker_stopped
    _worker_stopped = True
    raise KeyboardInterrupt


def _interrupt_when_orphaned() -> None:
    """SIGINT to this worker when the command's process ends, however it ends (SIGTERM, SIGKILL), rather than
    flying on with no one to read the results."""
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGINT), 0, 0, 0) != 0:
        print(f"{PROG}: warning: a worker cannot follow its parent: {os.strerror(ctypes.get_errno())}",
              file=sys.stderr)  # fmt: skip


def _start_worker(lock, next_position) -> None:  # type: ignore[no-untyped-def]  # multiprocessing's proxies
    global _worker_bar_position, _worker_parent
    _worker_parent = os.getppid()
    signal.signal(signal.SIGINT, _stop_worker)
    if sys.platform == "linux":
        _interrupt_when_orphaned()
    tqdm.set_lock(lock)
    with next_position.get_lock():
        _worker_bar_position = next_position.value
        next_position.value += 1


Flight = tuple[str, Controller]  # a scenario's name (its Scenario holds its trigger's function: not picklable)


def _scenario(name: str, args: argparse.Namespace) -> Scenario:
    """The experiment as flown: cut to --duration when given."""
    scenario = SCENARIOS[name]
    return scenario if args.duration is None else replace(scenario, duration_s=min(args.duration, scenario.duration_s))


def _fly_in_worker(name: str, controller: Controller, out: Path, args: argparse.Namespace) -> RunResult:
    if _worker_stopped:
        raise FlightFailed("not flown: the command was interrupted")
    try:
        return _fly(_scenario(name, args), controller, out, args, _worker_bar_position)
    finally:
        if _worker_stopped and os.getppid() != _worker_parent:
            os._exit(1)  # orphaned: the run's processes are gone (its finally), and no one waits for a result


def _figures(name: str, out: Path) -> list[Path]:
    return refresh_figures(SCENARIOS[name], out)


class FlightQueue:
    """Flies the runs `jobs` at a time and draws each scenario's figures once all of its runs have ended (in the
    workers too, beside the runs still flying)."""

    def __init__(self, out: Path, args: argparse.Namespace, jobs: int) -> None:
        self.out = out
        self.args = args
        self.jobs = jobs
        self.figures: dict[str, list[Path]] = {}  # by scenario, once `fly` is exhausted

    def fly(self, flights: list[Flight]) -> Iterator[tuple[Flight, RunResult | Exception]]:
        """Each flight with its result, or the FlightFailed/ScenarioError it ended with, as they finish."""
        left = Counter(name for name, _ in flights)
        if self.jobs == 1:
            for name, controller in flights:
                try:
                    result: RunResult | Exception = _fly(_scenario(name, self.args), controller, self.out, self.args)
                except (FlightFailed, ScenarioError) as exc:
                    result = exc
                yield (name, controller), result
                left[name] -= 1
                if not left[name]:
                    self.figures[name] = _figures(name, self.out)
            return
        context = multiprocessing.get_context("spawn")  # a clean interpreter: no threads or sockets inherited
        with ProcessPoolExecutor(self.jobs, mp_context=context, initializer=_start_worker,
                                 initargs=(context.RLock(), context.Value("i", 0))) as pool:  # fmt: skip
            futures = {pool.submit(_fly_in_worker, *flight, self.out, self.args): flight for flight in flights}
            drawing = {}
            for future in as_completed(futures):
                name, controller = futures[future]
                try:
                    result = future.result()
                except (FlightFailed, ScenarioError) as exc:
                    result = exc
                yield (name, controller), result
                left[name] -= 1
                if not left[name]:
                    drawing[name] = pool.submit(_figures, name, self.out)
            self.figures = {name: future.result() for name, future in drawing.items()}


def default_jobs(instance: int | None) -> int:
    """Two runs at a time where there are two cores: a lockstep pair mostly alternates, so one run leaves a core
    partly idle (docs/performance.md); one with --instance, whose ports only one run can use."""
    return 1 if instance is not None else min(2, len(os.sched_getaffinity(0)))


def scenario(args: argparse.Namespace) -> int:
    if args.jobs is not None and args.jobs > 1 and args.instance is not None:
        print(f"{PROG} scenario: error: --instance gives one vehicle's ports; it cannot go with --jobs {args.jobs}",
              file=sys.stderr)  # fmt: skip
        return 2
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
            if isinstance(result, Exception):
                print(f"{PROG}: {name} with the {controller} failed: {result}", file=sys.stderr)
                failed.append(f"{name}/{controller}")
                continue
            shown = {key: result.metrics.get(key) for key in SHOWN if result.metrics.get(key) is not None}
            print(f"{PROG}: {name} ({controller}): {result.sim_s:g} s flown in {result.wall_s:.1f} s; "
                  + ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in shown.items()))
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted: the runs in flight were stopped, their processes killed", file=sys.stderr)
        return 130
    for name in names:
        figures = queue.figures.get(name)
        if figures:
            print(f"{PROG}: {name}: figures in {figures[0].parent.parent}/*/")
        mpc_metrics = out / name / "mpc" / "metrics.json"
        if "mpc" in controllers and mpc_metrics.is_file() and args.duration is None:
            pid_path = out / name / "pid" / "metrics.json"
            pid = json.loads(pid_path.read_text()) if pid_path.is_file() else None
            for text, passed in acceptance(name, json.loads(mpc_metrics.read_text()), pid):
                print(f"{PROG}: {name}: MPC {text}: {'pass' if passed else 'FAIL'}")
    if args.name == "all":
        report = write_report(out, time.perf_counter() - started)
        print(f"{PROG}: report {report}")
    if failed:
        print(f"{PROG}: error: {len(failed)} run(s) failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0
