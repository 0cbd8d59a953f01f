"""`vtol up`: the plant in real time and the autopilot, ready for a ground station (docs/architecture.md).

`--count N` starts N vehicles, instances I .. I+N-1, as PX4's multi-vehicle SITL does: system ids I+1 .. I+N, every
GCS link sending to 14550 (one ground station sees the fleet), API links on 14540+I each, and the vehicles
FLEET_SPACING_M apart in a row to the east (each one's home; tiltrotor_sitl/_commands.py fleet_home).

Both processes print to this terminal. Ctrl-C (SIGINT to the terminal's process group) or SIGTERM to `vtol` stops
both: the signal is passed on to each, each stops at its next turn, and `vtol up` waits for them (killing a
process that has not stopped after STOP_TIMEOUT_S). If either process ends by itself (a port in use, a bad
parameter file), the other is stopped too and `vtol up` exits with its code. If `vtol up` is killed outright, the
kernel sends both SIGTERM (their parent-death signal, tiltrotor_sitl/_children.py).
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path

from autopilot.storage.parameters import ParameterFileError, ParameterStore, default_parameter_path, vehicle_system_id
from tiltrotor_sitl._children import Child, Stream, start, stop
from tiltrotor_sitl._commands import AutopilotCommand, SimCommand, Zenoh, fleet_home, plant_wind
from transport.cli import fail, stop_on_signals
from transport.ports import LOOPBACK, Ports
from transport.wind import Wind

PROG = "vtol"
STOP_TIMEOUT_S = 10.0


def commands(args: argparse.Namespace, index: int, sysid: int) -> tuple[list[str], list[str]]:
    """The vtol-sim and vtol-autopilot command lines of the `index`-th vehicle (system id `sysid`) for `vtol up`'s
    arguments (the first one at the default home, so a single vehicle is started as before)."""
    zenoh = Zenoh.off() if args.no_zenoh else Zenoh()
    instance = args.instance + index
    home = fleet_home(index) if index > 0 else None
    key = Path(args.plant_signing_key) if args.plant_signing_key else None
    plant = SimCommand(
        instance=instance,
        realtime_speed=args.speed,
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
        params=Path(args.params) if args.params else None,
        plant_signing_key=key,
    )
    return plant.argv(), autopilot.argv()


def wind(args: argparse.Namespace) -> Wind | None:
    """--wind, --turbulence, --wind-seed as the plant's wind (None: none given); refused in one line when out of
    range."""
    speed, direction = args.wind
    given = Wind(speed, direction, args.turbulence, args.wind_seed)
    try:
        given.check()
    except ValueError as exc:
        fail(PROG, str(exc))
    return None if given == Wind() else given


def system_id(args: argparse.Namespace, instance: int) -> int:
    """The system id the autopilot of `instance` will take (MAV_SYS_ID from its parameter file when changed, else
    instance + 1), given to its plant too, so both publish under the same zenoh keys."""
    params = ParameterStore(Path(args.params) if args.params else default_parameter_path(instance))
    try:
        params.load()
    except ParameterFileError as exc:
        fail(PROG, str(exc))
    return vehicle_system_id(params, instance)


def start_in_terminal(name: str, argv: list[str]) -> Child:
    """One process of `vtol up`, printing to this terminal, in its process group (a Ctrl-C reaches it too)."""
    return start(name, argv, stdout=Stream.INHERIT, stderr=Stream.INHERIT)


def up(args: argparse.Namespace) -> int:
    stop_requested = stop_on_signals()
    if args.count > 1 and args.params:
        fail(PROG, "--params names one vehicle's parameter file: it does not go with --count")
    processes: list[Child] = []
    sysids = [system_id(args, args.instance + index) for index in range(args.count)]
    for index, sysid in enumerate(sysids):
        ports = Ports(args.instance + index)
        plant_command, autopilot_command = commands(args, index, sysid)
        plant = start_in_terminal("vtol-sim", plant_command)
        autopilot = start_in_terminal("vtol-autopilot", autopilot_command)
        processes += [autopilot, plant]
        print(f"{PROG}: vehicle {sysid} (instance {ports.instance}): plant pid {plant.pid} "
              f"(real time x{args.speed:g}), autopilot pid {autopilot.pid}; "
              f"MAVSDK udpin://{LOOPBACK}:{ports.api_remote} (the vehicle listens on {ports.api_bind})",
              file=sys.stderr, flush=True)  # fmt: skip
    ports = Ports(args.instance)
    print(f"{PROG}: ground stations: QGroundControl or MAVProxy on udp {LOOPBACK}:{ports.gcs_remote} "
          f"(system id{'s' if args.count > 1 else ''} {', '.join(map(str, sysids))}); "
          f"Ctrl-C stops {'both' if args.count == 1 else 'all'}", file=sys.stderr, flush=True)  # fmt: skip
    code = 0
    while not stop_requested():
        ended = [p for p in processes if p.poll() is not None]
        if ended:
            process = ended[0]
            code = process.returncode or 1
            print(f"{PROG}: {process.name} ended (exit code {process.returncode}) (pid {process.pid}); "
                  f"stopping the {'other' if len(processes) == 2 else 'others'}", file=sys.stderr)  # fmt: skip
            break
        time.sleep(0.1)
    for process in stop(processes, signal.SIGINT if stop_requested() else signal.SIGTERM, STOP_TIMEOUT_S):
        print(f"{PROG}: pid {process.pid} did not stop within {STOP_TIMEOUT_S:g} s: killed", file=sys.stderr)
    print(f"{PROG}: stopped", file=sys.stderr, flush=True)
    return code
