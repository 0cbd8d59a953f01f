"""The autopilot's control path in one process: its cost per simulated second and a fingerprint of what it commanded.

    python benchmarks/bench_control_path.py [--seconds 10] [--rounds 5] [--controller both|mpc|pid] [--baseline DIR]

The plant (compiled RK4) and the flight controller fly the acceleration profile in closed loop at 400 Hz, no
sockets, no other process: the time inside the flight controller's step and the PWM encoding is the control path's
own, with none of the lockstep's waiting. It is measured as the thread's CPU time (what other processes on the
same cores take does not count), so a change of a few microseconds per step shows through a busy machine that the
whole SITL's factor (bench_sitl.py) cannot resolve. Two fingerprints: a hash of every step's 12 commands (to the
last bit) and one of every step's PWM (what goes on the wire): two trees that fly the same print the same ones.

Each flight runs in a process of its own, started as the lockstep flights are (address-space randomisation off,
a fixed hash seed: proxsuite's last bits follow its buffers' alignment, allocation.py), so that the fingerprint is
a function of the code alone. With `--baseline DIR` (a checkout of another commit) every round also flies on DIR's
code (this interpreter, DIR first on the path), in alternating order, and prints this tree's cost over the
baseline's, round by round, and whether the fingerprints agree.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

from bench_mpc import vehicle_state

from aircraft.actuators import command_to_pwm
from aircraft.airframe import load_airframe
from autopilot.controllers import build_flight_controller
from autopilot.topics.vehicle_state import VehicleState
from scenarios.profiles import accel
from sim_bridge.plant import Plant, Spawn
from tiltrotor_sitl._commands import deterministic_argv, deterministic_environment


def fly(controller_kind: str, seconds: float) -> dict:
    """One closed-loop flight: the control path's CPU milliseconds per simulated second, the commands' and the
    PWM's hashes."""
    airframe = load_airframe()
    plant = Plant(airframe, Spawn(altitude=100.0))
    controller = build_flight_controller(airframe, controller_kind)
    state = VehicleState()
    digest, wire = hashlib.sha256(), hashlib.sha256()
    busy = 0.0
    steps = int(round(seconds * 400))
    for _ in range(steps):
        vehicle_state(plant, state)
        state.specific_force[:] = plant.specific_force  # the accelerometer, which the velocity estimate uses
        if controller.velocity_due(state.time_usec):
            controller.set_velocity_setpoint(accel(state.time_s))
        started = time.thread_time()
        controller.step(state)
        pwm = command_to_pwm(airframe, controller.command)
        busy += time.thread_time() - started
        digest.update(controller.command.tobytes())
        wire.update(bytes(str(pwm), "ascii"))
        plant.set_command(controller.command)
        plant.step()
    return {"ms_per_s": busy / seconds * 1e3, "us_per_step": busy / steps * 1e6, "fingerprint": digest.hexdigest(),
            "pwm_fingerprint": wire.hexdigest()}  # fmt: skip


def fly_apart(controller_kind: str, seconds: float, directory: Path | None = None) -> dict:
    """`fly` in a deterministic process of its own, on this tree's code or on the checkout `directory`'s."""
    environment = deterministic_environment()
    if directory is not None:
        environment["PYTHONPATH"] = str(directory)
    command = deterministic_argv([sys.executable, str(Path(__file__).resolve()), "--one", controller_kind,
                                  "--seconds", str(seconds)])  # fmt: skip
    done = subprocess.run(command, cwd=directory or Path(__file__).resolve().parent.parent, env=environment,
                          check=True, capture_output=True, text=True)  # fmt: skip
    return json.loads(done.stdout.splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per flight")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--controller", choices=("both", "mpc", "pid"), default="both")
    parser.add_argument("--baseline", type=Path, metavar="DIR", help="also fly a checkout of another commit")
    parser.add_argument("--one", choices=("mpc", "pid"), help=argparse.SUPPRESS)  # one flight, JSON on stdout
    args = parser.parse_args()
    if args.one:
        print(json.dumps(fly(args.one, args.seconds)))
        return
    kinds = ["pid", "mpc"] if args.controller == "both" else [args.controller]
    print(f"accel profile, {args.seconds:g} s simulated in closed loop (one process), {args.rounds} rounds")
    for kind in kinds:
        here: list[dict] = []
        there: list[dict] = []
        for round_index in range(args.rounds):
            flights = [lambda: here.append(fly_apart(kind, args.seconds))]
            if args.baseline is not None:
                flights.append(lambda: there.append(fly_apart(kind, args.seconds, args.baseline)))
                flights = flights[::-1] if round_index % 2 else flights  # alternate which flies first
            for flight in flights:
                flight()
        report(kind, here, there, args.baseline)


def report(kind: str, here: list[dict], there: list[dict], baseline: Path | None) -> None:
    def median(runs: list[dict], key: str) -> float:
        return statistics.median(run[key] for run in runs)

    def line(label: str, runs: list[dict]) -> str:
        steady = all(run[key] == runs[0][key] for run in runs for key in ("fingerprint", "pwm_fingerprint"))
        return (
            f"{label}: control path {median(runs, 'ms_per_s'):.1f} CPU ms per simulated second "
            f"({median(runs, 'us_per_step'):.1f} us per step), commands {runs[0]['fingerprint'][:16]}, "
            f"PWM {runs[0]['pwm_fingerprint'][:16]}{'' if steady else ' (NOT the same in every round)'}"
        )

    print(line(kind, here))
    if baseline is None:
        return
    print(line(f"{kind}, baseline {baseline}", there))
    ratios = [a["ms_per_s"] / b["ms_per_s"] for a, b in zip(here, there)]
    same = {key: all(a[key] == b[key] for a, b in zip(here, there)) for key in ("fingerprint", "pwm_fingerprint")}
    print(f"  this / baseline, round by round: median {statistics.median(ratios):.3f} (min {min(ratios):.3f}, "
          f"max {max(ratios):.3f}; lower is better); as the baseline: commands {same['fingerprint']}, "
          f"PWM {same['pwm_fingerprint']}")  # fmt: skip


if __name__ == "__main__":
    main()
