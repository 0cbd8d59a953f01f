"""`vtol fly PROFILE [--controller mpc|pid] [--out DIR] [--duration S] [--spawn-alt M] [--no-progress]`.

Starts the plant and the autopilot in lockstep on free ports, flies one of the paper's velocity profiles with the
autopilot's internal set-point source (no ground station: ground_tools/lockstep_flight.py), with a progress bar in
simulated seconds, and writes the flight log, the processes' summaries and the figures to DIR/PROFILE/CONTROLLER/.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ground_tools.exit_status import FAILED, INTERRUPTED, OK, epilog
from ground_tools.figures import plot_flight
from ground_tools.lockstep_flight import FlightFailed, fly_lockstep
from ground_tools.progress import advance_to, sim_time_bar
from scenarios.profiles import PROFILES
from tiltrotor_sitl import Controller
from transport.cli import positive_float, writable_folder
from transport.flight_log import read_flight_log

PROG = "vtol"
EPILOG = epilog(ok="flown; the log and figures written", failed="the flight failed (a process exited with an error)")


def add_fly_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = EPILOG
    parser.add_argument("profile", choices=sorted(PROFILES), help="a velocity set-point profile of the paper")
    parser.add_argument("--controller", choices=("mpc", "pid"), default="mpc",
                        help="velocity controller (default mpc, the unified MPC)")  # fmt: skip
    parser.add_argument("--out", default="runs", metavar="DIR", help="output folder (default ./runs)")
    parser.add_argument("--duration", type=positive_float, metavar="S",
                        help="simulated seconds to fly (default: the profile's length)")  # fmt: skip
    parser.add_argument("--spawn-alt", type=positive_float, default=100.0, metavar="M",
                        help="start hovering at M metres (default 100)")  # fmt: skip
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def fly(args: argparse.Namespace) -> int:
    controller: Controller = args.controller
    duration = args.duration or PROFILES[args.profile][1]
    run_dir = writable_folder(PROG, Path(args.out) / args.profile / controller)
    log_path = run_dir / "flight.csv"
    bar = sim_time_bar(duration, f"{args.profile} ({controller})", disable=args.no_progress)
    try:
        flight = fly_lockstep(args.profile, duration, controller=controller, spawn_alt=args.spawn_alt,
                              log_path=log_path, on_progress=lambda sim_s: advance_to(bar, sim_s))  # fmt: skip
        advance_to(bar, duration)
    except FlightFailed as exc:
        print(f"{PROG}: error: the flight failed: {exc}", file=sys.stderr)
        return FAILED
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted: the flight was stopped, its processes killed", file=sys.stderr)
        return INTERRUPTED
    finally:
        bar.close()
    summary = {"autopilot": flight.autopilot, "plant": flight.plant}
    (run_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    figures = plot_flight(read_flight_log(log_path), run_dir, f"{args.profile}, {controller}")
    print(f"{PROG}: {flight.plant['sim_time_s']:g} s flown at {flight.plant['real_time_factor']}x real time")
    print(f"{PROG}: log {log_path}")
    for figure in figures:
        print(f"{PROG}: figure {figure}")
    return OK
