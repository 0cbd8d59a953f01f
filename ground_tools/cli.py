"""`vtol`: ground tools (docs/architecture.md).

    vtol fly PROFILE [--controller mpc|pid] [--out DIR] [--duration S] [--spawn-alt M] [--no-progress]
    vtol scenario NAME|all [--controller mpc|pid|both] [--out DIR] [--instance I] [--jobs J] [--no-record]
                           [--no-progress]
    vtol mission FILE.plan|FILE.waypoints [--controller mpc|pid|both] [--out DIR] [--no-progress]
    vtol campaign FILE [--out DIR] [--workers N | --address ADDR] [--report] [--no-progress]
    vtol up [--instance I] [--count N] [--controller mpc|pid] [--spawn-alt M] [--speed F] [--params FILE]
            [--log-dir DIR] [--no-zenoh]
    vtol record --out FILE.jsonl [--instance I | --connect ENDPOINT ...] [--sysid N|all] [--duration S]
                [--no-progress]
    vtol watch [--instance I | --connect ENDPOINT ...] [--sysid N] [--duration S] [--snapshot FILE.png] [--text]

`fly` flies one of the paper's velocity profiles with the autopilot's internal set-points (fly_command.py).
`scenario` flies the paper's experiments through MAVLink in lockstep and writes run folders, figures and a
report (ground_tools/scenario_command.py).
`mission` flies a mission file in lockstep, uploaded through the MAVLink mission protocol, with figures and each
waypoint's closest approach (ground_tools/mission_command.py).
`campaign` flies many scenario variants on a Dask cluster into a DuckDB store, with envelope maps (ground_tools/campaign/;
the campaign extra: pip install 'tiltrotor-sitl[campaign]').
`up` starts the plant in real time and the autopilot for a ground station (ground_tools/up.py).
`record` and `watch` record / show a running vehicle's zenoh telemetry (ground_tools/telemetry_record.py, watch.py).

Every command and subcommand has --version; each --help ends with what its exit statuses mean
(ground_tools/exit_status.py). Options that take a value name it with capitals: a letter for a number (I instance,
N count, S seconds, M metres, F factor, J jobs), a word for a path or an address (DIR, FILE, ADDR, ENDPOINT).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from ground_tools.campaign.arguments import add_campaign_arguments
from ground_tools.fly_command import add_fly_arguments, fly
from ground_tools.mission_command import add_mission_arguments, mission
from ground_tools.scenario_command import add_scenario_arguments, scenario
from ground_tools.telemetry_record import add_record_arguments, record
from ground_tools.up import add_up_arguments, up
from ground_tools.watch import add_watch_arguments, watch
from transport.cli import OneLineArgumentParser, fail

PROG = "vtol"
CAMPAIGN_MODULES = ("dask", "distributed", "duckdb", "pandas")  # the campaign extra (pyproject.toml)
COMMANDS = {
    "fly": "fly a paper velocity profile in lockstep (internal set-points) and plot it",
    "scenario": "fly a paper experiment through MAVLink, with metrics, figures and recordings",
    "mission": "fly a mission file (.plan, .waypoints) in lockstep through MAVLink, with figures and waypoint errors",
    "campaign": "fly a campaign of scenario variants on a Dask cluster, into a DuckDB store, with envelope maps",
    "up": "start the plant (real time) and the autopilot for a ground station",
    "record": "record a vehicle's zenoh telemetry (JSON lines)",
    "watch": "live view of a vehicle's zenoh telemetry",
}


def parser() -> OneLineArgumentParser:
    """`vtol`'s command line, every subcommand's with it."""
    top = OneLineArgumentParser(prog=PROG, description="tiltrotor-sitl ground tools",
                                epilog="exit status: 2 for bad arguments, refused in one line; each command's --help "
                                "says what its exit statuses mean.")  # fmt: skip
    commands = top.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                  parser_class=OneLineArgumentParser)  # fmt: skip
    adders = {"fly": add_fly_arguments, "scenario": add_scenario_arguments, "mission": add_mission_arguments,
              "campaign": add_campaign_arguments, "up": add_up_arguments, "record": add_record_arguments,
              "watch": add_watch_arguments}  # fmt: skip
    for name, summary in COMMANDS.items():
        adders[name](commands.add_parser(name, help=summary, description=summary))
    return top


def campaign_command() -> Callable[[argparse.Namespace], int]:
    """`vtol campaign`, imported on demand: Dask, DuckDB and pandas (the campaign extra) take 1.2 s to import, and
    only this command needs them; without them, one line naming the extra."""
    try:
        from ground_tools.campaign.command import campaign
    except ModuleNotFoundError as missing:
        if (missing.name or "").split(".")[0] not in CAMPAIGN_MODULES:
            raise
        fail(f"{PROG} campaign", f"needs {missing.name}, which comes with the campaign extra: pip install "
                                 f"'tiltrotor-sitl[campaign]'")  # fmt: skip
    return campaign


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if args.command == "campaign":
        return campaign_command()(args)
    run = {"fly": fly, "scenario": scenario, "mission": mission, "up": up, "record": record, "watch": watch}
    return run[args.command](args)


if __name__ == "__main__":
    sys.exit(main())
