"""What the ULog logger costs the control loop, two ways:

    python benchmarks/bench_ulog.py [--profile accel] [--rounds 5] [--controller mpc|pid] [--steps 40000]

1. the logger alone, in this process: Logger.step for `--steps` plant steps of a hovering vehicle (its median over
   five runs, in us a step), the work it adds to every plant step whatever the machine's load;
2. a paper profile flown in lockstep with the logger and without it (`--no-ulog`), alternated round by round so that
   a machine whose speed drifts meets both alike: each run's wall time and the autopilot's own work per plant step
   (busy_us_per_step), their medians, the log's size. Each flight is spawned hovering (armed: SDLOG_MODE 0 logs from
   the first step to the last).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from aircraft.airframe import load_airframe
from autopilot.commander.commander import build_commander
from autopilot.commander.failure_injection import FailureInjection
from autopilot.controllers import build_flight_controller
from autopilot.logger.logger import Logger, VehicleIdentity
from autopilot.storage.mission_store import MissionStore
from autopilot.storage.parameters import ParameterStore
from autopilot.storage.vehicle_files import VehicleFiles
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.vehicle_status import EventOutbox
from ground_tools.lockstep_flight import fly_lockstep
from scenarios.profiles import PROFILES
from transport.geodesy import Home


def run_once(profile: str, duration: float, controller: str, folder: Path, logging: bool) -> dict[str, float]:
    args = ("--params", str(folder / "params.json"), "--root", str(folder / "root"))
    flight = fly_lockstep(profile, duration, controller=controller, autopilot_args=args + (() if logging else
                          ("--no-ulog",)))  # fmt: skip
    logs = sorted((folder / "root" / "log").glob("*/*.ulg"))
    return {
        "wall_s": flight.autopilot["wall_time_s"],
        "busy_us_per_step": flight.autopilot["busy_us_per_step"],
        "log_bytes": logs[-1].stat().st_size if logging and logs else 0,
        "sim_s": flight.autopilot["sim_time_s"],
    }


def logger_alone_us(steps: int) -> float:
    """Logger.step's cost (us a plant step) for a hovering vehicle flown by the PID, its log in a scratch folder."""
    airframe = load_airframe(None)
    params, missions, events = ParameterStore(None), MissionStore(), EventOutbox()
    home = Home(47.397742, 8.545594, 488.0)
    commander = build_commander(params, airframe.hover_thrust_per_rotor / airframe.thrust_max, armed=True,
                                in_air=True, say=events.say, profile=None, stamped_setpoints=False, missions=missions,
                                home=home)  # fmt: skip
    controller = build_flight_controller(airframe, "pid", params)
    injection = FailureInjection(send=lambda failure: None, note=print, scheduled=[])
    with tempfile.TemporaryDirectory(prefix="bench-ulog-") as scratch:
        identity = VehicleIdentity(1, home, commander.navigator.ids, airframe.gravity,
                                   airframe.thrust_max * len(airframe.rotor_positions))  # fmt: skip
        logger = Logger(VehicleFiles.at(Path(scratch)), params, commander, missions, injection, identity)
        state, pwm = VehicleState(valid=True), [1500] * 12
        started = time.perf_counter()
        for step in range(steps):
            state.time_usec = 1_000_000 + step * 2500
            logger.step(state.time_usec, state, controller, pwm)
        elapsed = time.perf_counter() - started
        logger.close()
    return elapsed / steps * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--profile", choices=sorted(PROFILES), default="accel")
    parser.add_argument("--duration", type=float, help="simulated seconds (default: the profile's)")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--controller", choices=("mpc", "pid"), default="mpc")
    parser.add_argument("--steps", type=int, default=40_000, help="plant steps of the logger alone")
    args = parser.parse_args()
    alone = statistics.median(logger_alone_us(args.steps) for _ in range(5))
    print(f"the logger alone: {alone:.1f} us a plant step", flush=True)
    duration = args.duration or PROFILES[args.profile][1]
    results: dict[bool, list[dict[str, float]]] = {True: [], False: []}
    with tempfile.TemporaryDirectory(prefix="bench-ulog-") as scratch:
        for round_ in range(args.rounds):
            order = (True, False) if round_ % 2 == 0 else (False, True)
            for logging in order:
                folder = Path(scratch) / f"{round_}-{'log' if logging else 'nolog'}"
                folder.mkdir()
                result = run_once(args.profile, duration, args.controller, folder, logging)
                results[logging].append(result)
                print(f"round {round_ + 1} {'with' if logging else 'without'} the logger: {result['wall_s']:.2f} s wall "
                      f"for {result['sim_s']:.1f} s, autopilot {result['busy_us_per_step']:.0f} us/step"
                      + (f", log {result['log_bytes'] / 1e6:.2f} MB" if logging else ""), flush=True)  # fmt: skip
    for key, unit in (("wall_s", "s"), ("busy_us_per_step", "us/step")):
        with_log = statistics.median(r[key] for r in results[True])
        without = statistics.median(r[key] for r in results[False])
        print(
            f"median {key}: with {with_log:.2f} {unit}, without {without:.2f} {unit}, "
            f"difference {with_log - without:+.2f} {unit} ({(with_log / without - 1) * 100:+.1f} %)"
        )


if __name__ == "__main__":
    main()
