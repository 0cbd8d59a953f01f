"""`vtol`: ground tools (SPEC section 1).

    vtol fly PROFILE [--controller pid] [--out DIR] [--instance I]

`fly` starts the plant and the autopilot in lockstep on free ports, flies one of the paper's velocity profiles
with the autopilot's internal set-point source, and writes the flight log and figures to DIR/PROFILE/.
"""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from pathlib import Path

from autopilot.setpoint_profiles import PROFILES
from ground_tools.figures import plot_flight, read_log
from transport.cli import OneLineArgumentParser, fail, positive_float

PROG = "vtol"


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def fly(profile: str, controller: str, out: Path, duration: float, spawn_alt: float) -> int:
    run_dir = out / profile / controller
    run_dir.mkdir(parents=True, exist_ok=True)
    log_path = run_dir / "flight.csv"
    port = str(free_udp_port())
    plant = subprocess.Popen(
        [sys.executable, "-m", "sim_bridge", "--port", port, "--spawn-alt", str(spawn_alt), "--no-zenoh",
         "--duration", str(duration), "--summary"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        print(f"{PROG}: flying '{profile}' ({duration:g} s simulated) with the {controller} controller...",
              file=sys.stderr, flush=True)  # fmt: skip
        autopilot = subprocess.run(
            [sys.executable, "-m", "autopilot", "--sim-port", port, "--spawn-alt", str(spawn_alt),
             "--profile", profile, "--duration", str(duration), "--controller", controller,
             "--log", str(log_path), "--summary", "--no-zenoh"],
            capture_output=True, text=True,
        )  # fmt: skip
        plant_out, plant_err = plant.communicate(timeout=120)
    finally:
        if plant.poll() is None:
            plant.kill()
            plant.wait()
    if autopilot.returncode != 0 or plant.returncode != 0:
        fail(PROG, f"the flight failed: {autopilot.stderr.strip() or plant_err.strip()}")
    summary = {"autopilot": json.loads(autopilot.stdout.strip().splitlines()[-1]),
               "plant": json.loads(plant_out.strip().splitlines()[-1])}  # fmt: skip
    (run_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    figures = plot_flight(read_log(log_path), run_dir, f"{profile}, {controller}")
    print(f"{PROG}: {summary['plant']['sim_time_s']:g} s flown at {summary['plant']['real_time_factor']}x real time")
    print(f"{PROG}: log {log_path}")
    for figure in figures:
        print(f"{PROG}: figure {figure}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = OneLineArgumentParser(prog=PROG, description="tiltrotor-sitl ground tools")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=OneLineArgumentParser)
    fly_parser = commands.add_parser("fly", help="fly a paper velocity profile in lockstep and plot it")
    fly_parser.add_argument("profile", choices=sorted(PROFILES))
    fly_parser.add_argument("--controller", choices=("pid",), default="pid")
    fly_parser.add_argument("--out", default="runs", metavar="DIR", help="output folder (default ./runs)")
    fly_parser.add_argument("--duration", type=positive_float, metavar="S", help="default: the profile's")
    fly_parser.add_argument("--spawn-alt", type=positive_float, default=100.0, metavar="M")
    args = parser.parse_args(argv)
    duration = args.duration or PROFILES[args.profile][1]
    return fly(args.profile, args.controller, Path(args.out), duration, args.spawn_alt)


if __name__ == "__main__":
    sys.exit(main())
