"""A busy machine (docs/faults.md): the 40 s Offboard velocity profile flown from a pymavlink script against a paced
vehicle with the MPC, on a quiet machine and with a lockstep scenario running beside it on the same cores; prints
the velocity RMS error of each, their ratio, PID fall-backs, failsafes and the speed the simulation achieved.

    python benchmarks/bench_busy.py [--seconds 40] [--controller mpc]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from ground_tools.busy_flight import BusyFlight, fly_profile


def line(name: str, flight: BusyFlight) -> str:
    n, e, d = flight.rms_ned
    return (f"{name:<28} v RMS N/E/D {n:.3f} / {e:.3f} / {d:.3f} m/s, fell back to PID {flight.fell_back_to_pid}, "
            f"left Offboard {flight.offboard_left}, achieved speed x{flight.real_time_factor:.2f} "
            f"({flight.slowdowns} slow-downs), {flight.wall_s:.0f} s wall")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=40.0, help="profile length in simulated seconds")
    parser.add_argument("--controller", choices=("mpc", "pid"), default="mpc")
    args = parser.parse_args()
    beside = [sys.executable, "-m", "ground_tools", "scenario", "all", "--controller", "mpc", "--jobs", "1",
              "--no-record", "--no-progress"]  # fmt: skip
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        quiet = fly_profile(root / "quiet", args.seconds, args.controller)
        print(line("quiet", quiet), flush=True)
        busy = fly_profile(
            root / "busy", args.seconds, args.controller, beside=[*beside, "--out", str(root / "beside")]
        )
        print(line("lockstep scenario beside", busy), flush=True)
    ratios = [b / q for b, q in zip(busy.rms_ned, quiet.rms_ned, strict=True)]
    print("busy / quiet v RMS N/E/D: " + " / ".join(f"{r:.2f}" for r in ratios) + " (goal: each <= 1.20)")


if __name__ == "__main__":
    main()
