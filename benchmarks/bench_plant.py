"""Plant speed: lockstep real-time factor against a minimal echo peer, and the cost of the model's pieces.

    python benchmarks/bench_plant.py [--seconds 20] [--repeats 3]

Prints medians (and the spread over repeats). The echo peer is the smallest correct autopilot: it parses
each step's state and answers SERVO_OUTPUT_RAW with the hover command, so the figure is the plant's speed
plus one MAVLink round trip per step.
"""

from __future__ import annotations

import argparse
import json
import signal
import statistics
import time
from pathlib import Path

import casadi as ca
import numpy as np

from aircraft.actuators import command_to_pwm, pwm_to_command
from aircraft.airframe import load_airframe
from aircraft.wrench import body_wrench
from sim_bridge.plant import Plant, Spawn, hover_command
from sim_bridge.sensors import SensorSuite
from tiltrotor_sitl._children import Stream, start, stop
from tiltrotor_sitl._commands import SimCommand, Zenoh
from tiltrotor_sitl._free_ports import free_udp_port
from transport.geodesy import Home, LocalGeodetic
from transport.mavlink import Link
from transport.plant_link import PlantLinkClient


def median_us(function, repeats: int = 5000) -> float:
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        samples.append(time.perf_counter() - start)
    return statistics.median(samples) * 1e6


def component_costs() -> dict[str, float]:
    airframe = load_airframe()
    wrench = ca.Function(
        "wrench",
        [t := ca.SX.sym("t", 4), c := ca.SX.sym("c", 4), d := ca.SX.sym("d", 4), v := ca.SX.sym("v", 3), w := ca.SX.sym("w", 3)],
        list(body_wrench(airframe, t, c, d, v, w)),
    )  # fmt: skip
    args = [np.full(4, 10.0), np.full(4, 0.5), np.zeros(4), np.array([20.0, 0.0, 1.0]), np.zeros(3)]
    buffer, evaluate = wrench.buffer()
    outputs = [np.zeros(3), np.zeros(3)]
    for i, a in enumerate(args):
        buffer.set_arg(i, memoryview(a))
    for i, o in enumerate(outputs):
        buffer.set_res(i, memoryview(o))
    plant = Plant(airframe, Spawn(altitude=100.0))
    sensors = SensorSuite(plant, Link(1, 200), LocalGeodetic(Home()))
    pwm = command_to_pwm(airframe, hover_command(airframe))

    def sensor_step() -> None:
        plant.step()
        sensors.datagram()

    return {
        "model_evaluation_us": median_us(evaluate),
        "rk4_step_us": median_us(plant.step),
        "sensor_datagram_us": median_us(sensor_step) - median_us(plant.step),
        "pwm_decode_us": median_us(lambda: pwm_to_command(airframe, pwm, plant.command)),
    }


def lockstep_factor(seconds: float) -> dict[str, float]:
    """Run vtol-sim in lockstep against an in-process echo peer; simulated seconds per wall second."""
    airframe = load_airframe()
    port = free_udp_port()
    process = start("vtol-sim", SimCommand(port=port, spawn_alt=100.0, zenoh=Zenoh.off(), duration_s=seconds,
                                           summary=True).argv(), stdout=Stream.CAPTURE, stderr=Stream.CAPTURE)  # fmt: skip
    client = PlantLinkClient(port)
    pwm = command_to_pwm(airframe, hover_command(airframe))
    try:
        sample = None
        deadline = time.monotonic() + 30
        while sample is None and time.monotonic() < deadline:
            client.hello()
            sample = client.receive_step(0.2)
        if sample is None:
            raise RuntimeError("the plant did not start")
        began = time.perf_counter()
        steps = 0
        while sample is not None:
            client.send_pwm(sample.time_usec, pwm)
            steps += 1
            sample = client.receive_step(2.0)
        wall = time.perf_counter() - began - 2.0  # the last receive timed out after the plant finished
        process.wait(10)
    finally:
        client.close()
        stop([process], signal.SIGKILL)
    summary = process.summary()
    return {
        "steps": steps,
        "plant_real_time_factor": summary["real_time_factor"],
        "plant_alone_real_time_factor": summary["plant_alone_real_time_factor"],
        "peer_real_time_factor": round(steps / 400 / wall, 2),
        "per_step_us": round(summary["wall_time_s"] / max(summary["steps"], 1) * 1e6, 1),
        "missed_commands": summary["missed_commands"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per lockstep run")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the figures to FILE (JSON)")
    args = parser.parse_args()
    costs = component_costs()
    for name, value in costs.items():
        print(f"{name:28s} {value:8.1f} us (median)")
    runs = [lockstep_factor(args.seconds) for _ in range(args.repeats)]
    factors = [run["plant_real_time_factor"] for run in runs]
    per_step = [run["per_step_us"] for run in runs]
    print(
        f"lockstep real-time factor     median {statistics.median(factors):.1f}x "
        f"(min {min(factors):.1f}, max {max(factors):.1f}) over {args.repeats} runs of {args.seconds:g} s"
    )
    alone = [run["plant_alone_real_time_factor"] for run in runs]
    print(
        f"plant alone (its busy time)   median {statistics.median(alone):.1f}x real time "
        f"({1e6 / 400 / statistics.median(alone):.0f} us of plant work per step)"
    )
    print(
        f"wall time per physics step    median {statistics.median(per_step):.0f} us "
        f"(budget for 40x: {1e6 / 400 / 40:.0f} us)"
    )
    print(f"missed commands               {sum(run['missed_commands'] for run in runs)}")
    if args.json:
        figures = {"seconds": args.seconds, "repeats": args.repeats, "component_us": costs,
                   "lockstep_real_time_factor": statistics.median(factors),
                   "plant_alone_real_time_factor": statistics.median(alone),
                   "wall_us_per_step": statistics.median(per_step)}  # fmt: skip
        args.json.write_text(json.dumps(figures, indent=1) + "\n")


if __name__ == "__main__":
    main()
