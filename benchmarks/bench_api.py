"""Time from `Vehicle(...).start()` to ready to arm (HEARTBEAT past BOOT, HOME_POSITION, SYS_STATUS pre-arm check),
median of N starts; with --hover S, how many vehicles hover together for S simulated seconds (spawned at 20 m, real
time) with no failsafe and no fall-back to the PID: fleets of 1, 2, 3 ... until one vehicle leaves 20 +- 2 m or
its autopilot says it fell back.

    python benchmarks/bench_api.py [--runs 10] [--controller mpc|pid] [--hover 60] [--max-fleet 8]
"""

from __future__ import annotations

import argparse
import statistics
import time

from tiltrotor_sitl import Controller, Fleet, Vehicle

HOVER_ALT_M = 20.0
HOVER_BAND_M = 2.0
FALLBACK_WORDS = ("fall back", "fallback", "failsafe")


def time_to_ready(runs: int, controller: Controller) -> list[float]:
    times = []
    for _ in range(runs):
        started = time.monotonic()
        with Vehicle(controller=controller, truth=False):
            times.append(time.monotonic() - started)
    return times


def fleet_hovers(count: int, controller: Controller, seconds: float) -> tuple[bool, str]:
    """(every vehicle held its hover for `seconds` simulated seconds, why not)."""
    with Fleet(count, controller=controller, spawn_alt=HOVER_ALT_M) as fleet:
        start_t = [vehicle.truth.latest().t for vehicle in fleet.vehicles]
        deadline = time.monotonic() + seconds * 3 + 30
        while time.monotonic() < deadline:
            samples = [vehicle.truth.latest() for vehicle in fleet.vehicles]
            for vehicle, sample in zip(fleet.vehicles, samples):
                if abs(sample.altitude - HOVER_ALT_M) > HOVER_BAND_M:
                    return False, f"vehicle {vehicle.sysid} at {sample.altitude:.1f} m (t = {sample.t:.1f} s)"
                said = vehicle.stderr().lower()
                if any(word in said for word in FALLBACK_WORDS):
                    return False, f"vehicle {vehicle.sysid}: {said.strip().splitlines()[-1]}"
            if all(sample.t - t0 >= seconds for sample, t0 in zip(samples, start_t)):
                return True, ""
            time.sleep(0.5)
        return False, f"did not reach {seconds:g} simulated seconds in time (the machine is too slow for {count})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--controller", choices=("mpc", "pid"), default="mpc")
    parser.add_argument("--hover", type=float, default=0.0, metavar="S", help="also the hover test, S sim seconds")
    parser.add_argument("--max-fleet", type=int, default=8)
    args = parser.parse_args()
    times = time_to_ready(args.runs, args.controller)
    print(f"ready to arm ({args.controller}): median {statistics.median(times):.2f} s over {len(times)} starts "
          f"(min {min(times):.2f}, max {max(times):.2f})", flush=True)  # fmt: skip
    if args.hover > 0:
        best = 0
        for count in range(1, args.max_fleet + 1):
            ok, why = fleet_hovers(count, args.controller, args.hover)
            print(f"{count} vehicle(s), {args.controller}: {'hovered' if ok else 'failed: ' + why}", flush=True)
            if not ok:
                break
            best = count
        print(f"vehicles hovering together for {args.hover:g} s ({args.controller}): {best}")


if __name__ == "__main__":
    main()
