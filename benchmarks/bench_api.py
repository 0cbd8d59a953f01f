"""Time from `Vehicle(...).start()` to ready to arm (HEARTBEAT past BOOT, HOME_POSITION, SYS_STATUS pre-arm check),
median of N starts; with --hover S, how many vehicles of a `Fleet` hover together for S simulated seconds at real
time (paced lockstep, spawned hovering at 20 m in Hold), with the MPC and with the PID: fleets of 1, 2, 3 ... until
a vehicle fails. A vehicle fails when it falls (below 10 m or on the ground), fails safe (a "Failsafe" STATUSTEXT),
falls back from the MPC to the PID (its STATUSTEXT, or fell_back_to_pid in its summary), misses its hover point
by more than 2 m (the plant's truth, sampled every 0.2 s). A machine that cannot keep up slows the paced lockstep
down instead: each fleet's simulation speed is printed, the largest fleet that held at 0.9 x real time or better is
counted apart, and fleets stop growing once the simulation runs slower than 0.5 x real time (the machine is full).

With `--baseline DIR` (a checkout of another commit, e.g. `git worktree add DIR main`), each start of this tree
alternates with one of the baseline's, each in a fresh interpreter running its own tree's bench_api.py, and the
medians and the ratio of this tree over the baseline, round by round, are printed.

    python benchmarks/bench_api.py [--runs 10] [--controller mpc|pid] [--baseline DIR] [--hover 60] [--max-fleet 8]
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from baseline import run_in

from tiltrotor_sitl import Controller, Fleet, PlantTruth, ProcessOptions, Vehicle, VehicleHandle

HOVER_ALT_M = 20.0
HOVER_TOLERANCE_M = 2.0  # distance from the spawn point (0, 0, -20 m in the vehicle's own frame)
FALLEN_BELOW_M = 10.0
REAL_TIME = 0.9  # simulated seconds per wall second over the run, to count as real time
SATURATED = 0.5  # slower than this: no larger fleet is tried
TOO_SLOW = "did not reach"  # a fleet stopped for slowness, not for a vehicle's failure
POLL_S = 0.2


THIS_TREE = Path(__file__).resolve().parents[1]


def time_to_ready(controller: Controller) -> float:
    """Wall seconds from `Vehicle(...)` to ready to arm, in this interpreter."""
    started = time.monotonic()
    with Vehicle(controller=controller, truth=False):
        return time.monotonic() - started


def time_to_ready_of(directory: Path, controller: Controller, scratch: Path) -> float:
    """One start with the code of the checkout `directory`, in a fresh interpreter (its own bench_api.py)."""
    out = scratch / "start.json"
    command = [sys.executable, "benchmarks/bench_api.py", "--runs", "1", "--controller", controller, "--json", str(out)]
    run_in(command, directory, check=True, stdout=subprocess.DEVNULL)
    return float(json.loads(out.read_text())["ready_s_median"])


def report_ready(label: str, times: list[float]) -> None:
    """The medians line of one tree's starts."""
    print(f"ready to arm ({label}): median {statistics.median(times):.2f} s over {len(times)} starts "
          f"(min {min(times):.2f}, max {max(times):.2f})", flush=True)  # fmt: skip


def hover_error(truth: PlantTruth) -> float:
    north, east, down = truth.position_ned
    return math.sqrt(north**2 + east**2 + (down + HOVER_ALT_M) ** 2)


def what_went_wrong(vehicle: VehicleHandle, truth: PlantTruth) -> str | None:
    """Why `vehicle` failed its hover at this sample, or None."""
    if truth.on_ground or truth.altitude < FALLEN_BELOW_M:
        return f"vehicle {vehicle.sysid} fell: {truth.altitude:.1f} m at t = {truth.t:.1f} s"
    for line in vehicle.stderr().splitlines():
        if "Failsafe" in line:
            return f"vehicle {vehicle.sysid} failed safe: {line.strip()}"
        if "PID back-up" in line:
            return f"vehicle {vehicle.sysid} fell back to the PID: {line.strip()}"
    if hover_error(truth) > HOVER_TOLERANCE_M:
        return f"vehicle {vehicle.sysid} missed its hover by {hover_error(truth):.2f} m at t = {truth.t:.1f} s"
    return None


@dataclass
class HoverRun:
    """One fleet's hover: held or not, why not, the worst distance from the hover point, the simulation speed."""

    held: bool
    why: str
    worst_m: float
    real_time: float

    def describe(self) -> str:
        figures = f"worst {self.worst_m:.2f} m from the hover point, x{self.real_time:.2f} of real time"
        if self.held:
            return f"held ({figures})"
        return f"{'stopped' if self.why.startswith(TOO_SLOW) else 'failed'}: {self.why} ({figures})"


def fleet_hovers(count: int, controller: Controller, seconds: float) -> HoverRun:
    with tempfile.TemporaryDirectory(prefix="bench-api-") as folder:
        fleet = Fleet(
            count,
            controller=controller,
            spawn_alt=HOVER_ALT_M,
            folder=Path(folder),
            processes=ProcessOptions(summary=True),
        )
        with fleet:
            first = [vehicle.truth.latest() for vehicle in fleet.vehicles]
            began, worst, why = time.monotonic(), 0.0, ""
            deadline = began + seconds / SATURATED + 10
            while not why:
                samples = [vehicle.truth.latest() for vehicle in fleet.vehicles]
                worst = max(worst, *(hover_error(sample) for sample in samples))
                why = next((w for v, s in zip(fleet.vehicles, samples) if (w := what_went_wrong(v, s))), "")
                if all(sample.t - start.t >= seconds for sample, start in zip(samples, first)):
                    break
                if time.monotonic() > deadline:
                    why = f"{TOO_SLOW} {seconds:g} simulated seconds within {deadline - began:.0f} wall seconds"
                    samples = [vehicle.truth.latest() for vehicle in fleet.vehicles]
                time.sleep(POLL_S)
            wall = time.monotonic() - began
            real_time = min(sample.t - start.t for sample, start in zip(samples, first)) / wall
        fell_back = [v.sysid for v in fleet.vehicles if v.summary().get("controller", {}).get("fell_back_to_pid")]
    if not why and fell_back:
        why = f"vehicle(s) {fell_back} fell back to the PID (summary)"
    return HoverRun(not why, why, worst, real_time)


def hover_capacity(controller: Controller, seconds: float, max_fleet: int) -> tuple[int, int]:
    """Print each fleet size's outcome; (the largest fleet that held, the largest that held at real time)."""
    held = at_real_time = 0
    for count in range(1, max_fleet + 1):
        run = fleet_hovers(count, controller, seconds)
        print(f"  {count} vehicle(s), {controller}: {run.describe()}", flush=True)
        if not run.held:
            break
        held = count
        at_real_time = count if run.real_time >= REAL_TIME and at_real_time == count - 1 else at_real_time
        if run.real_time < SATURATED:
            print(f"  (slower than x{SATURATED} of real time: the machine is full; no larger fleet tried)")
            break
    return held, at_real_time


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--controller", choices=("mpc", "pid"), default="mpc", help="for the time to ready")
    parser.add_argument("--hover", type=float, default=0.0, metavar="S", help="also the hover test, S sim seconds")
    parser.add_argument("--max-fleet", type=int, default=8)
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the figures to FILE (JSON)")
    parser.add_argument("--baseline", type=Path, metavar="DIR", help="also start a checkout of another commit")
    args = parser.parse_args()
    times, baseline = [], []
    with tempfile.TemporaryDirectory() as scratch:
        for _ in range(args.runs):
            if args.baseline is None:
                times.append(time_to_ready(args.controller))
            else:  # both alike: a fresh interpreter each
                times.append(time_to_ready_of(THIS_TREE, args.controller, Path(scratch)))
                baseline.append(time_to_ready_of(args.baseline, args.controller, Path(scratch)))
    report_ready(args.controller, times)
    if baseline:
        report_ready(f"{args.controller}, baseline {args.baseline}", baseline)
        ratios = [here / there for here, there in zip(times, baseline)]
        print(f"  this / baseline: median {statistics.median(ratios):.3f} (min {min(ratios):.3f}, "
              f"max {max(ratios):.3f})")  # fmt: skip
    figures: dict[str, object] = {"controller": args.controller, "starts": len(times),
                                  "ready_s_median": statistics.median(times), "ready_s_max": max(times)}  # fmt: skip
    if args.hover > 0:
        found: dict[Controller, tuple[int, int]] = {}
        for controller in ("mpc", "pid"):
            print(f"hovering together for {args.hover:g} s at {HOVER_ALT_M:g} m, paced at real time ({controller}):",
                  flush=True)  # fmt: skip
            found[controller] = hover_capacity(controller, args.hover, args.max_fleet)
        figures["hover_s"] = args.hover
        figures["fleets"] = {controller: {"held": held, "at_real_time": at_real_time}
                             for controller, (held, at_real_time) in found.items()}  # fmt: skip
        for controller, (held, at_real_time) in found.items():
            print(f"vehicles hovering together for {args.hover:g} s ({controller}): {held} held, {at_real_time} of "
                  f"them at x{REAL_TIME} of real time or better")  # fmt: skip

    if args.json:
        args.json.write_text(json.dumps(figures, indent=1) + "\n")


if __name__ == "__main__":
    main()
