"""`vtol`: ground tools (docs/architecture.md).

    vtol fly PROFILE [--controller pid|mpc] [--out DIR]
    vtol scenario NAME|all [--controller mpc|pid|both] [--out DIR] [--instance I] [--jobs J] [--no-record]
                           [--no-progress]
    vtol mission FILE.plan|FILE.waypoints [--controller mpc|pid|both] [--out DIR]
    vtol campaign FILE [--out DIR] [--workers N | --address ADDR] [--report] [--no-progress]
    vtol up [--instance I] [--count N] [--controller mpc|pid] [--spawn-alt M] [--speed F] [--params FILE] [--no-zenoh]
            [--wind SPEED,FROM_DEG] [--turbulence SIGMA] [--wind-seed N]
    vtol record --out FILE.jsonl [--instance I | --connect ENDPOINT ...] [--sysid N|all] [--duration S]
    vtol watch [--instance I | --connect ENDPOINT ...] [--sysid N] [--duration S] [--snapshot FILE.png] [--text]

`fly` starts the plant and the autopilot in lockstep on free ports, flies one of the paper's velocity profiles
with the autopilot's internal set-point source, and writes the flight log and figures to DIR/PROFILE/.
`scenario` flies the paper's experiments through MAVLink in lockstep and writes run folders, figures and a
report (ground_tools/scenario_command.py).
`mission` flies a mission file in lockstep, uploaded through the MAVLink mission protocol, with figures and each
waypoint's closest approach (ground_tools/mission_command.py).
`campaign` flies many scenario variants on a Dask cluster into a DuckDB store, with envelope maps (ground_tools/campaign/).
`up` starts the plant in real time and the autopilot for a ground station (ground_tools/up.py).
`record` and `watch` record / show a running vehicle's zenoh telemetry (ground_tools/telemetry_record.py, watch.py).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ground_tools.campaign.arguments import add_campaign_arguments
from ground_tools.figures import plot_flight
from ground_tools.lockstep_flight import FlightFailed, fly_lockstep
from ground_tools.mission_command import add_mission_arguments, mission
from ground_tools.scenario_command import add_scenario_arguments, scenario
from ground_tools.telemetry_record import add_record_arguments, record
from ground_tools.up import up
from ground_tools.watch import add_watch_arguments, watch
from scenarios.profiles import PROFILES
from tiltrotor_sitl import Controller
from transport.cli import (
    OneLineArgumentParser,
    bounded_int,
    fail,
    finite_float,
    nonnegative_float,
    positive_float,
    writable_folder,
)
from transport.flight_log import read_flight_log
from transport.plant_parameters import SEED_MAX

PROG = "vtol"


def wind_speed_and_direction(text: str) -> tuple[float, float]:
    """'SPEED,FROM_DEG' -> two finite numbers (their ranges are checked with the rest of the wind)."""
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"expected SPEED,FROM_DEG: {text!r}")
    speed, direction = (finite_float(part) for part in parts)
    return speed, direction


def fly(profile: str, controller: Controller, out: Path, duration: float, spawn_alt: float) -> int:
    run_dir = writable_folder(PROG, out / profile / controller)
    log_path = run_dir / "flight.csv"
    print(f"{PROG}: flying '{profile}' ({duration:g} s simulated) with the {controller} controller...",
          file=sys.stderr, flush=True)  # fmt: skip
    try:
        flight = fly_lockstep(profile, duration, controller=controller, spawn_alt=spawn_alt, log_path=log_path)
    except FlightFailed as exc:
        fail(PROG, f"the flight failed: {exc}")
    summary = {"autopilot": flight.autopilot, "plant": flight.plant}
    (run_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    figures = plot_flight(read_flight_log(log_path), run_dir, f"{profile}, {controller}")
    print(f"{PROG}: {flight.plant['sim_time_s']:g} s flown at {flight.plant['real_time_factor']}x real time")
    print(f"{PROG}: log {log_path}")
    for figure in figures:
        print(f"{PROG}: figure {figure}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = OneLineArgumentParser(prog=PROG, description="tiltrotor-sitl ground tools")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=OneLineArgumentParser)
    fly_parser = commands.add_parser("fly", help="fly a paper velocity profile in lockstep and plot it")
    fly_parser.add_argument("profile", choices=sorted(PROFILES))
    fly_parser.add_argument("--controller", choices=("mpc", "pid"), default="pid")
    fly_parser.add_argument("--out", default="runs", metavar="DIR", help="output folder (default ./runs)")
    fly_parser.add_argument("--duration", type=positive_float, metavar="S", help="default: the profile's")
    fly_parser.add_argument("--spawn-alt", type=positive_float, default=100.0, metavar="M")
    add_scenario_arguments(
        commands.add_parser(
            "scenario", help="fly a paper experiment through MAVLink, with metrics, figures and recordings"
        )
    )
    add_mission_arguments(
        commands.add_parser(
            "mission",
            help="fly a mission file (.plan, .waypoints) in lockstep through MAVLink, with figures and waypoint errors",
        )
    )
    add_campaign_arguments(
        commands.add_parser(
            "campaign",
            help="fly a campaign of scenario variants on a Dask cluster, into a DuckDB store, with envelope maps",
        )
    )
    up_parser = commands.add_parser("up", help="start the plant (real time) and the autopilot for a ground station")
    up_parser.add_argument("--instance", type=bounded_int(0, 999), default=0, help="shift every port by I")
    up_parser.add_argument(
        "--count",
        type=bounded_int(1, 100),
        default=1,
        metavar="N",
        help="start N vehicles: instances I..I+N-1, system ids I+1..I+N, 5 m apart (default 1)",
    )
    up_parser.add_argument("--controller", choices=("mpc", "pid"), help="default: the VT_CTRL parameter")
    up_parser.add_argument(
        "--spawn-alt",
        type=nonnegative_float,
        default=0.0,
        metavar="M",
        help="start hovering at M metres, armed, in Hold (default: on the ground, disarmed)",
    )
    up_parser.add_argument(
        "--speed", type=positive_float, default=1.0, metavar="F", help="simulated seconds per wall second (default 1)"
    )
    up_parser.add_argument("--params", metavar="FILE", help="the autopilot's parameter file")
    up_parser.add_argument("--wind", type=wind_speed_and_direction, default=(0.0, 0.0), metavar="SPEED,FROM_DEG",
                           help="mean wind: its speed (m/s) and where it blows from (deg, 90 = from the east); "
                                "SIM_WIND_SPD, SIM_WIND_DIR")  # fmt: skip
    up_parser.add_argument("--turbulence", type=nonnegative_float, default=0.0, metavar="SIGMA",
                           help="Dryden turbulence, the vertical gusts' standard deviation (m/s); SIM_WIND_TURB")  # fmt: skip
    up_parser.add_argument("--wind-seed", type=bounded_int(0, SEED_MAX), default=0, metavar="N",
                           help="the turbulence's seed (SIM_WIND_SEED)")  # fmt: skip
    up_parser.add_argument(
        "--plant-signing-key",
        metavar="FILE",
        help="sign each vehicle's plant link with this key (64 hex digits; docs/plant-link.md)",
    )
    up_parser.add_argument("--no-zenoh", action="store_true", help="no zenoh telemetry")
    add_record_arguments(commands.add_parser("record", help="record a vehicle's zenoh telemetry (JSON lines)"))
    add_watch_arguments(commands.add_parser("watch", help="live view of a vehicle's zenoh telemetry"))
    args = parser.parse_args(argv)
    if args.command == "up":
        return up(args)
    if args.command == "scenario":
        return scenario(args)
    if args.command == "mission":
        return mission(args)
    if args.command == "campaign":
        # Dask, DuckDB and pandas take 1.2 s to import: only this command pays for them.
        from ground_tools.campaign.command import campaign

        return campaign(args)
    if args.command == "record":
        return record(args)
    if args.command == "watch":
        return watch(args)
    duration = args.duration or PROFILES[args.profile][1]
    return fly(args.profile, args.controller, Path(args.out), duration, args.spawn_alt)


if __name__ == "__main__":
    sys.exit(main())
