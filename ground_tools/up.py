"""`vtol up`: the plant in real time and the autopilot, ready for a ground station (docs/architecture.md).

Both processes print to this terminal. Ctrl-C (SIGINT to the terminal's process group) or SIGTERM to `vtol` stops
both: the signal is passed on to each, each stops at its next turn, and `vtol up` waits for them (killing a
process that has not stopped after STOP_TIMEOUT_S). If either process ends by itself (a port in use, a bad
parameter file), the other is stopped too and `vtol up` exits with its code.
"""

from __future__ import annotations

import argparse
import signal
import subprocess
import sys
import time
from pathlib import Path

from ground_tools.processes import AutopilotCommand, SimCommand, Zenoh
from transport.cli import stop_on_signals
from transport.ports import LOOPBACK, Ports

PROG = "vtol"
STOP_TIMEOUT_S = 10.0


def commands(args: argparse.Namespace) -> tuple[list[str], list[str]]:
    """The vtol-sim and vtol-autopilot command lines for `vtol up`'s arguments."""
    zenoh = Zenoh.off() if args.no_zenoh else Zenoh()
    plant = SimCommand(instance=args.instance, realtime_speed=args.speed, spawn_alt=args.spawn_alt, zenoh=zenoh)
    autopilot = AutopilotCommand(instance=args.instance, spawn_alt=args.spawn_alt, zenoh=zenoh,
                                 controller=args.controller, params=Path(args.params) if args.params else None)
    return plant.argv(), autopilot.argv()


def stop(processes: list[subprocess.Popen], signum: int = signal.SIGTERM) -> None:
    for process in processes:
        if process.poll() is None:
            try:
                process.send_signal(signum)
            except ProcessLookupError:
                pass
    deadline = time.monotonic() + STOP_TIMEOUT_S
    for process in processes:
        try:
            process.wait(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            print(f"{PROG}: pid {process.pid} did not stop within {STOP_TIMEOUT_S:g} s: killed", file=sys.stderr)
            process.kill()
            process.wait()


def up(args: argparse.Namespace) -> int:
    stop_requested = stop_on_signals()
    plant_command, autopilot_command = commands(args)
    ports = Ports(args.instance)
    plant = subprocess.Popen(plant_command)
    autopilot = subprocess.Popen(autopilot_command)
    processes = [autopilot, plant]
    print(f"{PROG}: plant pid {plant.pid} (real time x{args.speed:g}), autopilot pid {autopilot.pid}\n"
          f"{PROG}: ground stations: QGroundControl or MAVProxy on udp {LOOPBACK}:{ports.gcs_remote} "
          f"(the vehicle listens on {ports.gcs_bind}), MAVSDK udpin://{LOOPBACK}:{ports.api_remote} "
          f"(the vehicle listens on {ports.api_bind}); Ctrl-C stops both", file=sys.stderr, flush=True)  # fmt: skip
    code = 0
    while not stop_requested():
        ended = [p for p in processes if p.poll() is not None]
        if ended:
            process = ended[0]
            name = "vtol-autopilot" if process is autopilot else "vtol-sim"
            code = process.returncode or 1
            print(f"{PROG}: {name} ended (exit code {process.returncode}); stopping the other", file=sys.stderr)
            break
        time.sleep(0.1)
    stop(processes, signal.SIGINT if stop_requested() else signal.SIGTERM)
    print(f"{PROG}: stopped", file=sys.stderr, flush=True)
    return code
