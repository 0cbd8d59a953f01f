"""Where a simulated second goes in the lockstep SITL: the autopilot's pieces under cProfile, the plant's work.

    python benchmarks/bench_sitl_breakdown.py [--controller mpc|pid] [--overlap 0|1] [--profile accel]
                                              [--duration 10] [--json FILE]

Flies the profile twice in lockstep (vtol-sim + vtol-autopilot, no ground station, no zenoh, no log): once as it
is, for the real wall time and each process's own work, and once with the autopilot under cProfile, for the
shares of its pieces. The profiler inflates Python-heavy code (each call costs about 1 us more), so the table
gives each piece's profiled time per simulated second and the same scaled to the unprofiled autopilot's work.
"""

from __future__ import annotations

import argparse
import json
import pstats
import sys
import tempfile
from pathlib import Path

from bench_sitl import overlap_params

from ground_tools.lockstep_flight import LockstepFlight, fly_lockstep
from scenarios.profiles import PROFILES

# (label, module file, function): cumulative time of the function, the calls within it included
PIECES = [
    ("autopilot loop (PlantLoop.run)", "plant_loop.py", "run"),
    ("  plant link receive (waiting + parse)", "plant_link.py", "receive_step"),
    ("    waiting for the plant's datagram (udp.receive)", "udp.py", "receive"),
    ("    parse of the plant's datagram", "mavlink.py", "parse"),
    ("  HIL_STATE_QUATERNION -> state", "topics/vehicle_state.py", "update_from_hil_state"),
    ("  commander tick (100 Hz)", "commander/commander.py", "tick"),
    ("  flight controller step", "control/flight_controller.py", "step"),
    ("    velocity estimate", "control/velocity_estimate.py", "update"),
    ("    MPC tick, synchronous (MpcVelocityController.update)", "mpc/controller.py", "update"),
    ("      RTI solve (RtiSolver.solve, the C call inside)", "mpc/rti.py", "solve"),
    ("      set-point parameters", "mpc/controller.py", "_set_parameters"),
    ("      warm-start shift", "mpc/rti.py", "shift"),
    ("    MPC tick, overlapped (OverlappedMpc.update, waiting included)", "mpc/overlap.py", "update"),
    ("      the tick up to the solve (MpcVelocityController._prepare)", "mpc/controller.py", "_prepare"),
    ("      waiting for the solve (the C back-end's worker thread)", "mpc/hpipm.py", "finish"),
    ("    PID tick", "control/pid_baseline.py", "update"),
    ("    attitude loop + allocation (250 Hz)", "control/flight_controller.py", "_attitude_and_allocation"),
    ("      attitude loop", "control/attitude.py", "update"),
    ("      allocation QP", "control/allocation.py", "allocate"),
    ("    servo estimate", "control/actuator_health.py", "advance"),
    ("  PWM encoding", "actuators.py", "command_to_pwm"),
    ("  SERVO_OUTPUT_RAW framed + sent", "plant_link.py", "send_pwm"),
    ("  MAVLink services: receive", "mavlink/services.py", "receive"),
    ("  MAVLink services: publish (streams)", "mavlink/services.py", "publish"),
    ("  VehicleStatus snapshot", "plant_loop.py", "_status"),
]


def fly(profile: str, duration: float, controller: str, params: Path, profile_to: Path | None) -> LockstepFlight:
    return fly_lockstep(profile, duration, controller=controller, autopilot_args=("--params", str(params)),
                        autopilot_profile=profile_to)  # fmt: skip


def cumulative(stats: pstats.Stats, module: str, function: str) -> tuple[float, int]:
    """Seconds spent in `function` of `module` (calls within included; recursion counted once), and its calls."""
    seconds, calls = 0.0, 0
    for (filename, _, name), (primitive, _, _, cumulative_s, _) in stats.stats.items():  # type: ignore[attr-defined]
        if name == function and filename.endswith("/" + module):
            seconds += cumulative_s
            calls += primitive
    return seconds, calls


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--controller", choices=("mpc", "pid"), default="mpc")
    parser.add_argument("--overlap", type=int, choices=(0, 1), default=1, help="VT_MPC_OVERLAP")
    parser.add_argument("--profile", choices=sorted(PROFILES), default="accel")
    parser.add_argument("--duration", type=float, default=10.0, help="simulated seconds")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the table to FILE (JSON)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        params = overlap_params(Path(scratch) / "params.json", args.overlap)
        plain = fly(args.profile, args.duration, args.controller, params, None)
        profile_path = Path(scratch) / "autopilot.prof"
        fly(args.profile, args.duration, args.controller, params, profile_path)
        stats = pstats.Stats(str(profile_path))
    ap, pl = plain.autopilot, plain.plant
    sim_s, steps = pl["sim_time_s"], pl["steps"]
    wall_ms = pl["wall_time_s"] / sim_s * 1e3
    autopilot_busy_ms = ap["busy_us_per_step"] * steps / sim_s / 1e3
    plant_busy_ms = pl["busy_time_s"] / sim_s * 1e3
    print(
        f"{args.profile}, {args.duration:g} s simulated, {args.controller}"
        f"{f', VT_MPC_OVERLAP {args.overlap}' if args.controller == 'mpc' else ''}, lockstep, no ground station"
    )
    print(f"unprofiled: {pl['real_time_factor']:.1f}x real time; per simulated second: wall {wall_ms:.0f} ms, "
          f"autopilot work {autopilot_busy_ms:.0f} ms, plant work {plant_busy_ms:.0f} ms")  # fmt: skip
    run_s, _ = cumulative(stats, "plant_loop.py", "run")
    receive_s, _ = cumulative(stats, "plant_link.py", "receive_step")
    scale = autopilot_busy_ms / ((run_s - receive_s) / sim_s * 1e3) if run_s > receive_s else 1.0
    print(f"{'piece':66} {'calls/s':>8} {'ms/s profiled':>14} {'ms/s scaled':>12}")
    pieces = []
    for label, module, function in PIECES:
        seconds, calls = cumulative(stats, module, function)
        if calls == 0:
            continue
        per_second = seconds / sim_s * 1e3
        print(f"{label:66} {calls / sim_s:8.0f} {per_second:14.1f} {per_second * scale:12.1f}")
        pieces.append({"piece": label, "calls_per_s": calls / sim_s, "ms_per_s": per_second * scale})
    print(f"(scaled: profiled times x {scale:.2f}, the unprofiled autopilot's work over the profiled one's outside "
          f"the plant link's receive)")  # fmt: skip
    if args.json:
        args.json.write_text(json.dumps({
            "profile": args.profile, "seconds": args.duration, "controller": args.controller, "overlap": args.overlap,
            "real_time_factor": pl["real_time_factor"], "wall_ms_per_s": wall_ms,
            "autopilot_ms_per_s": autopilot_busy_ms, "plant_ms_per_s": plant_busy_ms, "pieces": pieces,
        }, indent=1))  # fmt: skip


if __name__ == "__main__":
    sys.exit(main())
