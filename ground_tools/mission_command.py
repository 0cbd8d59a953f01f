"""`vtol mission FILE.plan|FILE.waypoints [--controller mpc|pid|both] [--out DIR] [--no-progress]` (docs/missions.md).

Flies the mission file with each controller (ground_tools/mission_run.py), prints and writes each waypoint's
closest approach and the landing error, and draws the flights overlaid into `<out>/<mission>/`:

    ground_track.png  north over east: the tracks, the waypoints with their acceptance circles, home
    speed.png         horizontal speed and its set-point
    tilt.png          the rotors' mean tilt (0 deg: up, multicopter; 90 deg: forward, fixed wing)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ground_tools.exit_status import CHECK_FAILED, FAILED, INTERRUPTED, OK, epilog
from ground_tools.figures import pyplot, save_ground_track
from ground_tools.metrics import mean_tilt
from ground_tools.mission_file import MissionFileError, read_mission_file
from ground_tools.mission_run import MissionResult, MissionRunFailed, fly_mission
from ground_tools.progress import advance_to, items_bar
from ground_tools.scenario_figures import _style
from tiltrotor_sitl import Controller
from transport import flight_log
from transport.cli import fail, writable_folder

PROG = "vtol"
FIGURE_FILES = ("ground_track.png", "speed.png", "tilt.png")


EPILOG = epilog(ok="flown and every waypoint reached", failed="a flight failed (its error on stderr)",
                check_failed="flown, but a waypoint was missed (MISSED)")  # fmt: skip


def add_mission_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = EPILOG
    parser.add_argument("file", metavar="FILE", help="a QGroundControl .plan or a QGC WPL 110 .waypoints file")
    parser.add_argument(
        "--controller",
        choices=("mpc", "pid", "both"),
        default="mpc",
        help="velocity controller(s) to fly (default mpc)",
    )
    parser.add_argument("--out", default="runs", metavar="DIR", help="output folder (default ./runs)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def plot_mission(results: list[MissionResult], logs: dict[str, flight_log.FlightLog], folder: Path) -> list[Path]:
    """The three figures of the flights in `logs` (controller -> log), overlaid."""
    plt = pyplot()
    title = results[0].mission
    figure, axis = plt.subplots(figsize=(7, 7))
    for controller, log in logs.items():
        colour, line = _style(controller)
        axis.plot(log[flight_log.EAST], log[flight_log.NORTH], color=colour, linestyle=line, label=controller.upper())
    for waypoint in results[0].waypoints:
        axis.add_patch(plt.Circle((waypoint.east, waypoint.north), waypoint.acceptance_m, fill=False, color="black",
                                  linewidth=0.8))  # fmt: skip
        axis.plot(waypoint.east, waypoint.north, "k+")
        axis.annotate(str(waypoint.seq), (waypoint.east, waypoint.north), textcoords="offset points", xytext=(6, 6))
    axis.plot(0.0, 0.0, "k^", label="home")
    written = [save_ground_track(figure, axis, f"{title}: ground track, waypoints and acceptance circles",
                                 folder / "ground_track.png")]  # fmt: skip
    panels = (("horizontal speed (m/s)", "speed.png",
               lambda log: np.hypot(log[flight_log.VN], log[flight_log.VE]),
               lambda log: np.hypot(log[flight_log.VN_SP], log[flight_log.VE_SP])),
              ("mean rotor tilt (deg)", "tilt.png", lambda log: np.degrees(mean_tilt(log)), None))  # fmt: skip
    for label, name, value, setpoint in panels:
        figure, axis = plt.subplots(figsize=(9, 3.5))
        for controller, log in logs.items():
            colour, line = _style(controller)
            axis.plot(log[flight_log.T], value(log), color=colour, linestyle=line, label=controller.upper())
            if setpoint is not None:
                axis.plot(log[flight_log.T], setpoint(log), color=colour, linestyle=":", linewidth=1.0,
                          label=f"set-point ({controller.upper()})")  # fmt: skip
        axis.set_xlabel("t (s) from the start")
        axis.set_ylabel(label)
        axis.grid(True, alpha=0.3)
        axis.legend(loc="best", fontsize="small")
        axis.set_title(title)
        figure.tight_layout()
        figure.savefig(folder / name, dpi=110)
        plt.close(figure)
        written.append(folder / name)
    return written


def report_lines(result: MissionResult) -> list[str]:
    head = f"{result.mission} ({result.controller}): {result.sim_s:g} s flown in {result.wall_s:g} s"
    lines = [head] + [f"  item {w.seq}: closest {w.closest_m:.2f} m (acceptance {w.acceptance_m:g} m) "
                      f"{'reached' if w.reached else 'MISSED'}" for w in result.waypoints]  # fmt: skip
    return lines + [f"  landed {result.landing_error_m:.2f} m from home"]


def mission(args: argparse.Namespace) -> int:
    path = Path(args.file)
    try:
        rows = read_mission_file(path)
    except MissionFileError as exc:
        fail(PROG, f"{path}: {exc}")
    out = writable_folder(PROG, Path(args.out))
    controllers: list[Controller] = ["mpc", "pid"] if args.controller == "both" else [args.controller]
    results, logs, failed = [], {}, []
    for controller in controllers:
        bar = items_bar(len(rows), f"{path.name} ({controller})", "items", disable=args.no_progress)

        def progress(sim_s: float, item: int, bar: tqdm = bar) -> None:
            advance_to(bar, item)
            bar.set_postfix_str(f"t = {sim_s:.0f} s simulated", refresh=False)

        try:
            result = fly_mission(rows, path.stem, controller, out, on_progress=progress)
            advance_to(bar, len(rows))
        except MissionRunFailed as exc:
            tqdm.write(f"{PROG}: {path.name} with the {controller} failed: {exc}", file=sys.stderr)
            failed.append(controller)
            continue
        except KeyboardInterrupt:
            print(f"{PROG}: interrupted: the flight was stopped, its processes killed", file=sys.stderr)
            return INTERRUPTED
        finally:
            bar.close()
        results.append(result)
        logs[controller] = flight_log.read_flight_log(result.run_dir / "flight.csv")
        print("\n".join(f"{PROG}: {line}" for line in report_lines(result)))
    if results:
        figures = plot_mission(results, logs, out / path.stem)
        print(f"{PROG}: figures {', '.join(str(f) for f in figures)}")
    if failed:
        print(f"{PROG}: error: the flight(s) with {', '.join(failed)} failed", file=sys.stderr)
        return FAILED
    missed = [f"{r.controller} item {w.seq}" for r in results for w in r.waypoints if not w.reached]
    if missed:
        print(f"{PROG}: error: waypoint(s) missed: {', '.join(missed)}", file=sys.stderr)
        return CHECK_FAILED
    return OK
