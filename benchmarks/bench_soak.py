"""Soak: a vehicle hovering for hours of simulated time with a ground station talking, to show that neither process
grows and that a step costs the same at the end as at the start.

Each controller's vehicle (tiltrotor_sitl.Vehicle, the plant paced at --speed) hovers at 30 m in Hold while a
pymavlink ground station sends, every simulated second, a HEARTBEAT, a PARAM_REQUEST_READ and a
MAV_CMD_REQUEST_MESSAGE (HOME_POSITION), and reads everything the vehicle sends. Every --sample-s wall seconds the
benchmark reads both processes' resident memory (VmRSS, /proc) and the simulation time (the plant's truth on zenoh).
After --warm-up-minutes of simulated time it prints:
- per process, the resident memory at the end of the warm-up and at the end, and its growth per simulated hour
  (least-squares slope over the samples after the warm-up);
- the wall time per plant step (2.5 ms simulated), the median of each wall minute's samples, and the drift in per
  cent between the median of the first and of the last DRIFT_WINDOW_MINUTES of them (one loaded minute is noise).
  Where the vehicle keeps up with --speed this is the pace's own (2.5 ms / speed): a dearer step shows only once it
  no longer fits; `--speed 0` flies in lockstep as fast as the processes go, where it
  is the cost of a step itself. (CPU time would not tell: both processes spin briefly while they wait for each
  other in lockstep.)

    python benchmarks/bench_soak.py                          # both controllers, 2 simulated hours each, x16
    python benchmarks/bench_soak.py --controller mpc --minutes 10 --warm-up-minutes 2
"""

from __future__ import annotations

import argparse
import os
import statistics
import threading
import time
from dataclasses import dataclass, field

import numpy as np
from pymavlink import mavutil

from tiltrotor_sitl import Vehicle

STEP_S = 0.0025  # one plant step of simulated time
DRIFT_WINDOW_MINUTES = 5  # the drift compares the medians of the first and the last this many wall minutes
HOME_POSITION = 242
PAGE_KB = os.sysconf("SC_PAGE_SIZE") / 1024


@dataclass
class Sample:
    wall_s: float
    sim_s: float
    rss_kb: dict[str, float]


@dataclass
class Talker:
    """The ground station: asks something every simulated second, reads everything."""

    url: str
    target: int
    asked: int = 0
    heard: int = 0
    stop: threading.Event = field(default_factory=threading.Event)

    def run(self) -> None:
        conn = mavutil.mavlink_connection(self.url, source_system=255, source_component=190, dialect="common")
        next_s = 0.0
        try:
            while not self.stop.is_set():
                message = conn.recv_match(blocking=True, timeout=0.05)
                if message is None or message.get_type() == "BAD_DATA":
                    continue
                self.heard += 1
                sim_s = getattr(message, "time_boot_ms", None)
                if sim_s is None or sim_s / 1000.0 < next_s:
                    continue
                next_s = sim_s / 1000.0 + 1.0
                conn.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                conn.mav.param_request_read_send(self.target, 1, b"MPC_XY_CRUISE", -1)
                conn.mav.command_long_send(self.target, 1, mavutil.mavlink.MAV_CMD_REQUEST_MESSAGE, 0, HOME_POSITION,
                                           0, 0, 0, 0, 0, 0)  # fmt: skip
                self.asked += 1
        finally:
            conn.close()


def resident_kb(pid: int) -> float:
    with open(f"/proc/{pid}/statm") as statm:
        return int(statm.read().split()[1]) * PAGE_KB


def soak(controller: str, minutes: float, warm_up_minutes: float, speed: float | None,
         sample_s: float) -> list[Sample]:  # fmt: skip
    samples: list[Sample] = []
    with Vehicle(controller=controller, spawn_alt=30.0, speed=speed) as vehicle:
        pids = {"plant": vehicle.process("vtol-sim").pid, "autopilot": vehicle.process("vtol-autopilot").pid}
        talker = Talker(vehicle.pymavlink, vehicle.sysid)
        thread = threading.Thread(target=talker.run, daemon=True)
        thread.start()
        end_s = (warm_up_minutes + minutes) * 60.0
        try:
            while True:
                sim_s = vehicle.truth.latest().t
                samples.append(Sample(time.monotonic(), sim_s, {n: resident_kb(pid) for n, pid in pids.items()}))
                if sim_s >= end_s:
                    break
                if not vehicle.running():
                    raise RuntimeError(f"a process ended: {vehicle.stderr()[-500:]}")
                time.sleep(sample_s)
        finally:
            talker.stop.set()
            thread.join(timeout=5)
        print(f"  ground station: {talker.asked} rounds of requests, {talker.heard} messages heard")
    return samples


def report(controller: str, samples: list[Sample], warm_up_minutes: float) -> None:
    after = [s for s in samples if s.sim_s >= warm_up_minutes * 60.0]
    if len(after) < 3:
        print(f"{controller}: too few samples after the warm-up ({len(after)})")
        return
    span_h = (after[-1].sim_s - after[0].sim_s) / 3600.0
    wall_s = after[-1].wall_s - after[0].wall_s
    print(f"{controller}: {span_h * 60:.1f} simulated minutes after a {warm_up_minutes:g}-minute warm-up, "
          f"{wall_s:.0f} wall s (x{span_h * 3600 / wall_s:.1f})")  # fmt: skip
    sim = np.array([s.sim_s for s in after]) / 3600.0
    for name in ("plant", "autopilot"):
        rss_mb = np.array([s.rss_kb[name] for s in after]) / 1024.0
        slope = float(np.polyfit(sim, rss_mb, 1)[0])
        print(f"  {name:9s} RSS {rss_mb[0]:7.2f} -> {rss_mb[-1]:7.2f} MB: {rss_mb[-1] - rss_mb[0]:+.2f} MB in all, "
              f"{slope:+.3f} MB per simulated hour")  # fmt: skip
    per_minute = step_time_per_minute(after)
    span = max(1, min(DRIFT_WINDOW_MINUTES, len(per_minute) // 2))
    first, last = statistics.median(per_minute[:span]), statistics.median(per_minute[-span:])
    print(f"  wall time per plant step, median of each wall minute (us): "
          f"{' '.join(f'{m * 1e6:.0f}' for m in per_minute)}")  # fmt: skip
    print(f"  the first {span} minutes' median {first * 1e6:6.1f} us, the last {span} minutes' {last * 1e6:6.1f} us: "
          f"drift {100 * (last / first - 1):+.1f} % over {len(per_minute)} minutes")  # fmt: skip


def step_time_per_minute(samples: list[Sample]) -> list[float]:
    """Wall seconds per plant step between consecutive samples, the median of each wall minute's."""
    minutes: dict[int, list[float]] = {}
    start = samples[0].wall_s
    for a, b in zip(samples, samples[1:]):
        steps = (b.sim_s - a.sim_s) / STEP_S
        if steps > 0:
            minutes.setdefault(int((b.wall_s - start) // 60), []).append((b.wall_s - a.wall_s) / steps)
    return [statistics.median(values) for _, values in sorted(minutes.items())]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--controller", choices=("mpc", "pid", "both"), default="both")
    parser.add_argument("--minutes", type=float, default=120.0, help="simulated minutes after the warm-up")
    parser.add_argument("--warm-up-minutes", type=float, default=5.0, help="simulated minutes before measuring")
    parser.add_argument(
        "--speed",
        type=float,
        default=16.0,
        help="the plant's pace (simulated s per wall s); 0: lockstep as fast as the processes go",
    )
    parser.add_argument("--sample-s", type=float, default=2.0, help="wall seconds between samples")
    args = parser.parse_args()
    for controller in ("mpc", "pid") if args.controller == "both" else (args.controller,):
        print(f"{controller}: soaking at " + (f"x{args.speed:g}" if args.speed > 0 else "lockstep, as fast as it goes"))
        samples = soak(controller, args.minutes, args.warm_up_minutes, args.speed or None, args.sample_s)
        report(controller, samples, args.warm_up_minutes)


if __name__ == "__main__":
    main()
