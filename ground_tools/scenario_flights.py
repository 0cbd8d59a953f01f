"""The runs of `vtol scenario`, flown J at a time: in process (J = 1) or in a pool of worker processes, each run its
own lockstep plant and autopilot (ground_tools/scenario_run.py), and each scenario's figures once its runs have
ended. A worker stops its run as on Ctrl-C on SIGINT or SIGTERM, which it also gets when the command's process ends
however it ends (Linux: prctl PR_SET_PDEATHSIG), so no run flies on with no one to read it."""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import shutil
import signal
import sys
from collections import Counter
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import replace
from multiprocessing.sharedctypes import Synchronized
from pathlib import Path
from typing import Any

from tqdm import tqdm

from ground_tools.lockstep_client import START_MS, ScenarioError
from ground_tools.lockstep_flight import FlightFailed
from ground_tools.progress import advance_to, sim_time_bar
from ground_tools.scenario_figures import plot_scenario
from ground_tools.scenario_run import RunResult, run_scenario
from scenarios.experiments import SCENARIOS, Scenario
from tiltrotor_sitl import Controller
from tiltrotor_sitl._children import follow_parent
from transport.flight_log import FlightLog, read_flight_log

PROG = "vtol"

Flight = tuple[str, Controller]  # a scenario's name (its Scenario holds its trigger's function: not picklable)
Outcome = RunResult | FlightFailed | ScenarioError


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


# The paper's experiments assume a failure known the moment it happens: the controllers are told by the injection
# (the oracle), not by the failure detector, which is the autopilot's default (docs/failures.md).
PAPER_ASSUMPTIONS = {"VT_FAIL_ORACLE": 1}


def flown_scenario(name: str, args: argparse.Namespace) -> Scenario:
    """The experiment as flown: cut to --duration when given."""
    scenario = SCENARIOS[name]
    return scenario if args.duration is None else replace(scenario, duration_s=min(args.duration, scenario.duration_s))


def fly(name: str, controller: Controller, out: Path, args: argparse.Namespace, bar_position: int = 0) -> Outcome:
    """One run with its progress bar; its FlightFailed or ScenarioError as the outcome when it fails."""
    scenario = flown_scenario(name, args)
    total = START_MS / 1000.0 + scenario.duration_s
    bar = sim_time_bar(total, f"{scenario.name} ({controller})", disable=args.no_progress, position=bar_position)
    try:
        return run_scenario(
            scenario,
            controller,
            out,
            instance=args.instance,
            record=not args.no_record,
            mpc_horizon=args.mpc_horizon,
            autopilot_params=PAPER_ASSUMPTIONS,
            on_progress=lambda sim_s: advance_to(bar, sim_s),
        )
    except (FlightFailed, ScenarioError) as exc:
        return exc
    finally:
        bar.close()


def draw_figures(name: str, out: Path) -> list[Path]:
    return refresh_figures(SCENARIOS[name], out)


# ---- a worker process ----------------------------------------------------------------------------------------------
class _Worker:
    """A worker's own state (module-level: the pool calls plain functions)."""

    parent = 0  # the command's process id
    bar_position = 0  # its progress-bar line
    stopped = False  # Ctrl-C or SIGTERM, or the command's process has ended
    flying = False  # a run is in flight


def _stop(signum: int, frame: object) -> None:
    """A run in flight stops as on Ctrl-C (its run's `finally` kills its plant and autopilot); no further run starts.
    A second signal while it stops changes nothing: raised inside that `finally`, it would leave the autopilot
    running. Between runs an orphaned worker just ends; one whose command lives on waits to be told to."""
    again = _Worker.stopped
    _Worker.stopped = True
    if _Worker.flying:
        if not again:
            raise KeyboardInterrupt
        return
    if os.getppid() != _Worker.parent:
        os._exit(1)


def _start_worker(parent: int, lock: Any, next_position: Synchronized) -> None:
    """The pool's initializer. `lock`: tqdm's (a multiprocessing RLock), so that the workers' bars do not interleave."""
    _Worker.parent = parent
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, _stop)
    # SIGINT to this worker when the command's process ends, however it ends (SIGTERM, SIGKILL).
    if sys.platform == "linux" and not follow_parent(parent, signal.SIGINT):
        print(f"{PROG}: warning: a worker cannot follow its parent (prctl PR_SET_PDEATHSIG refused)", file=sys.stderr)
    tqdm.set_lock(lock)
    with next_position.get_lock():
        _Worker.bar_position = next_position.value
        next_position.value += 1


def _fly_in_worker(name: str, controller: Controller, out: Path, args: argparse.Namespace) -> Outcome:
    _Worker.flying = True
    try:
        if _Worker.stopped:
            return FlightFailed("not flown: the command was interrupted")
        return fly(name, controller, out, args, _Worker.bar_position)
    finally:
        _Worker.flying = False
        if _Worker.stopped and os.getppid() != _Worker.parent:
            os._exit(1)  # orphaned: the run's processes are gone (its finally), and no one waits for a result


# ---- the queue -----------------------------------------------------------------------------------------------------
class FlightQueue:
    """Flies the runs `jobs` at a time and draws each scenario's figures once all of its runs have ended (with more
    than one job, in the workers, beside the runs still flying)."""

    def __init__(self, out: Path, args: argparse.Namespace, jobs: int) -> None:
        self.out = out
        self.args = args
        self.jobs = jobs
        self.figures: dict[str, list[Path]] = {}  # by scenario, once `fly` is exhausted

    def fly(self, flights: list[Flight]) -> Iterator[tuple[Flight, Outcome]]:
        """Each flight with its result, or the FlightFailed/ScenarioError it ended with, as they finish."""
        if self.jobs == 1:
            yield from self._in_process(flights)
        else:
            yield from self._in_workers(flights)

    def _ended(self, flight: Flight, left: Counter[str], draw: Callable[[str], None]) -> None:
        left[flight[0]] -= 1
        if not left[flight[0]]:
            draw(flight[0])

    def _in_process(self, flights: list[Flight]) -> Iterator[tuple[Flight, Outcome]]:
        left = Counter(name for name, _ in flights)

        def draw(name: str) -> None:
            self.figures[name] = draw_figures(name, self.out)

        for flight in flights:
            yield flight, fly(*flight, self.out, self.args)
            self._ended(flight, left, draw)

    def _in_workers(self, flights: list[Flight]) -> Iterator[tuple[Flight, Outcome]]:
        left = Counter(name for name, _ in flights)
        context = multiprocessing.get_context("spawn")  # a clean interpreter: no threads or sockets inherited
        pool = ProcessPoolExecutor(self.jobs, mp_context=context, initializer=_start_worker,
                                   initargs=(os.getpid(), context.RLock(), context.Value("i", 0)))  # fmt: skip
        drawing: dict[str, Future[list[Path]]] = {}

        def draw(name: str) -> None:
            drawing[name] = pool.submit(draw_figures, name, self.out)

        try:
            futures = {pool.submit(_fly_in_worker, *flight, self.out, self.args): flight for flight in flights}
            for future in as_completed(futures):
                try:
                    outcome = future.result()
                except BrokenProcessPool as exc:  # a worker died (killed, out of memory): its runs are lost
                    outcome = FlightFailed(f"its worker process ended: {exc}")
                yield futures[future], outcome
                self._ended(futures[future], left, draw)
            self.figures = {name: future.result() for name, future in drawing.items()}
        except BaseException:
            pool.shutdown(wait=True, cancel_futures=True)  # no queued run starts; the runs in flight stop (Ctrl-C)
            raise
        pool.shutdown(wait=True)
