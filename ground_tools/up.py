"""`vtol up`: the plant in real time and the autopilot, ready for a ground station (docs/architecture.md).

`--count N` starts N vehicles, instances I .. I+N-1, as PX4's multi-vehicle SITL does: system ids I+1 .. I+N, every
GCS link sending to 14550 (one ground station sees the fleet), API links on 14540+I each, and the vehicles
FLEET_SPACING_M apart in a row to the east (each one's home; tiltrotor_sitl/_commands.py fleet_home).

Both processes print to this terminal. Ctrl-C (SIGINT to the terminal's process group) or SIGTERM to `vtol` stops
both: the signal is passed on to each, each stops at its next turn, and `vtol up` waits for them (killing a
process that has not stopped after STOP_TIMEOUT_S). If either process ends by itself (a port in use, a bad
parameter file), the other is stopped too and `vtol up` exits with status 1 (the line before says the process's own code). If `vtol up` is killed outright, the
kernel sends both SIGTERM (their parent-death signal, tiltrotor_sitl/_children.py).
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path

from autopilot.storage.parameters import ParameterFileError, ParameterStore, default_parameter_path, vehicle_system_id
from ground_tools.exit_status import FAILED, OK, epilog
from tiltrotor_sitl._children import Child, Stream, start, stop
from tiltrotor_sitl._commands import AutopilotCommand, SimCommand, Zenoh, fleet_home, plant_wind
from transport.cli import bounded_int, fail, finite_float, ipv4_address, nonnegative_float, stop_on_signals
from transport.plant_parameters import SEED_MAX
from transport.ports import LOOPBACK, Ports
from transport.wind import Wind

PROG = "vtol"
STOP_TIMEOUT_S = 10.0


EPILOG = epilog(ok="stopped by Ctrl-C or SIGTERM", failed="a process ended by itself (the other ones were stopped)")


def add_up_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = EPILOG
    parser.add_argument("--instance", type=bounded_int(0, 999), default=0, metavar="I",
                        help="shift every port by I (default 0; docs/plant-link.md)")  # fmt: skip
    parser.add_argument("--count", type=bounded_int(1, 100), default=1, metavar="N",
                        help="start N vehicles: instances I..I+N-1, system ids I+1..I+N, 5 m apart (default 1)")  # fmt: skip
    parser.add_argument("--controller", choices=("mpc", "pid"),
                        help="velocity controller (default: the VT_CTRL parameter, whose default is mpc)")  # fmt: skip
    parser.add_argument("--spawn-alt", type=nonnegative_float, default=0.0, metavar="M",
                        help="start hovering at M metres, armed, in Hold (default: on the ground, disarmed)")  # fmt: skip
    parser.add_argument("--speed", type=nonnegative_float, default=1.0, metavar="F",
                        help="simulated seconds per wall second (default 1; 0: lockstep as fast as possible)")  # fmt: skip
    parser.add_argument("--params", metavar="FILE", help="the autopilot's parameter file")
    parser.add_argument("--reset-params", action="store_true",
                        help="reset every parameter to its default in each vehicle's parameter file before the start "
                             "(as MAV_CMD_PREFLIGHT_STORAGE param1 2; the signing key stays)")  # fmt: skip
    parser.add_argument("--gcs-bind", type=ipv4_address, metavar="ADDR",
                        help="the GCS links listen on this IPv4 address (default 127.0.0.1; 0.0.0.0: every interface, "
                             "for QGroundControl on another machine)")  # fmt: skip
    parser.add_argument("--log-dir", metavar="DIR",
                        help="write the ULogs to DIR/YYYY-MM-DD/HH_MM_SS.ulg (with --count: DIR/vehicle-<sysid>/...; "
                        "default: the vehicle's root, microsd-I beside its parameter file)")  # fmt: skip
    parser.add_argument("--plant-signing-key", metavar="FILE",
                        help="sign each vehicle's plant link with this key (64 hex digits; docs/plant-link.md)")  # fmt: skip
    parser.add_argument("--wind", type=wind_from, default=(0.0, 0.0), metavar="N,E",
                        help="the mean wind, m/s from the north and from the east as PX4's SIH_WIND_N, SIH_WIND_E "
                        "(5,0: 5 m/s from the north; default none)")  # fmt: skip
    parser.add_argument("--wind-turbulence", type=nonnegative_float, default=0.0, metavar="SIGMA",
                        help="Dryden turbulence, the vertical gusts' standard deviation, m/s (SIM_WIND_TURB; "
                        "default 0: none)")  # fmt: skip
    parser.add_argument("--wind-seed", type=bounded_int(0, SEED_MAX), default=0, metavar="N",
                        help="the turbulence's seed (SIM_WIND_SEED; default 0)")  # fmt: skip
    parser.add_argument("--no-zenoh", action="store_true", help="no zenoh telemetry")


def wind_from(text: str) -> tuple[float, float]:
    """'N,E' -> two finite numbers (their ranges are checked with the rest of the wind)."""
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"expected N,E (m/s from the north and from the east): {text!r}")
    north, east = (finite_float(part) for part in parts)
    return north, east


def commands(args: argparse.Namespace, index: int, sysid: int) -> tuple[list[str], list[str]]:
    """The vtol-sim and vtol-autopilot command lines of the `index`-th vehicle (system id `sysid`) for `vtol up`'s
    arguments (the first one at the default home, so a single vehicle is started as before)."""
    zenoh = Zenoh.off() if args.no_zenoh else Zenoh()
    instance = args.instance + index
    home = fleet_home(index) if index > 0 else None
    key = Path(args.plant_signing_key) if args.plant_signing_key else None
    log_dir = None
    if args.log_dir:
        log_dir = Path(args.log_dir) if args.count == 1 else Path(args.log_dir) / f"vehicle-{sysid}"
    plant = SimCommand(
        instance=instance,
        realtime_speed=args.speed or None,
        spawn_alt=args.spawn_alt,
        zenoh=zenoh,
        home=home,
        plant_signing_key=key,
        sysid=sysid,
        **plant_wind(wind(args)),
    )
    autopilot = AutopilotCommand(
        instance=instance,
        spawn_alt=args.spawn_alt,
        zenoh=zenoh,
        home=home,
        controller=args.controller,
        gcs_bind=args.gcs_bind,
        params=Path(args.params) if args.params else None,
        plant_signing_key=key,
        log_dir=log_dir,
    )
    return plant.argv(), autopilot.argv()


def wind(args: argparse.Namespace) -> Wind | None:
    """--wind, --wind-turbulence, --wind-seed as the plant's wind (None: none given); refused in one line when out of
    range."""
    from_north, from_east = args.wind
    given = Wind(from_north, from_east, args.wind_turbulence, args.wind_seed)
    try:
        given.check()
    except ValueError as exc:
        fail(PROG, str(exc))
    return None if given == Wind() else given


def system_id(args: argparse.Namespace, instance: int) -> int:
    """The system id the autopilot of `instance` will take (MAV_SYS_ID from its parameter file when changed, else
    instance + 1), given to its plant too, so both publish under the same zenoh keys. With --reset-params the file
    is reset to the defaults first."""
    params = ParameterStore(Path(args.params) if args.params else default_parameter_path(instance))
    try:
        params.load()
    except ParameterFileError as exc:
        fail(PROG, str(exc))
    if args.reset_params:
        params.reset()
        error = params.flush()
        if error:
            fail(PROG, f"cannot reset the parameter file {params.path}: {error}")
    return vehicle_system_id(params, instance)


def start_in_terminal(name: str, argv: list[str]) -> Child:
    """One process of `vtol up`, printing to this terminal, in its process group (a Ctrl-C reaches it too)."""
    return start(name, argv, stdout=Stream.INHERIT, stderr=Stream.INHERIT)


def up(args: argparse.Namespace) -> int:
    stop_requested = stop_on_signals()
    if args.count > 1 and args.params:
        fail(PROG, "--params names one vehicle's parameter file: it does not go with --count")
    processes: list[Child] = []
    pacing = f"real time x{args.speed:g}" if args.speed else "lockstep, as fast as it goes"
    sysids = [system_id(args, args.instance + index) for index in range(args.count)]
    for index, sysid in enumerate(sysids):
        ports = Ports(args.instance + index)
        plant_command, autopilot_command = commands(args, index, sysid)
        plant = start_in_terminal("vtol-sim", plant_command)
        autopilot = start_in_terminal("vtol-autopilot", autopilot_command)
        processes += [autopilot, plant]
        print(f"{PROG}: vehicle {sysid} (instance {ports.instance}): plant pid {plant.pid} "
              f"({pacing}), autopilot pid {autopilot.pid}; "
              f"MAVSDK udpin://{LOOPBACK}:{ports.api_remote} (the vehicle listens on {ports.api_bind})",
              file=sys.stderr, flush=True)  # fmt: skip
    ports = Ports(args.instance)
    print(f"{PROG}: ground stations: QGroundControl or MAVProxy on udp {LOOPBACK}:{ports.gcs_remote} "
          f"(system id{'s' if args.count > 1 else ''} {', '.join(map(str, sysids))}); "
          f"Ctrl-C stops {'both' if args.count == 1 else 'all'}", file=sys.stderr, flush=True)  # fmt: skip
    code = OK
    while not stop_requested():
        ended = [p for p in processes if p.poll() is not None]
        if ended:
            process = ended[0]
            code = FAILED
            print(f"{PROG}: {process.name} ended (exit code {process.returncode}) (pid {process.pid}); "
                  f"stopping the {'other' if len(processes) == 2 else 'others'}", file=sys.stderr)  # fmt: skip
            break
        time.sleep(0.1)
    for process in stop(processes, signal.SIGINT if stop_requested() else signal.SIGTERM, STOP_TIMEOUT_S):
        print(f"{PROG}: pid {process.pid} did not stop within {STOP_TIMEOUT_S:g} s: killed", file=sys.stderr)
    print(f"{PROG}: stopped", file=sys.stderr, flush=True)
    return code
