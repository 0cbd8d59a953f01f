"""Campaign throughput: the same small campaign (`vtol campaign`, as a user runs it) on a local cluster of 1 and
of 2 workers; prints flights per minute for each (the whole command: cluster start, flights, store, report) and
the scaling ratio.

    python benchmarks/bench_campaign.py [--flights 8] [--duration 3] [--controller mpc] [--repeats 1]
                                        [--baseline DIR]

Each round flies into a fresh folder, so every point is flown. On a machine with 2 cores a flight's three
processes (plant, autopilot, ground station) already use more than one core, so the ratio is below 2. With
`--baseline DIR` (a checkout of another commit) each round also runs the campaign with DIR's code, alternately, and
this tree's flights per minute over the baseline's are printed.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import duckdb
from baseline import ratio_summary, run_in


def campaign_text(flights: int, duration: float, controller: str) -> str:
    jams = ", ".join(str(round(-7 + 102 * i / max(flights - 1, 1), 3)) for i in range(flights))
    return (f'scenario = "servo-failure"\ncontrollers = ["{controller}"]\n[fixed]\nduration_s = {duration}\n'
            f"jam_speed_mps = 1.0\n[axes]\njam_deg = [{jams}]\n")  # fmt: skip


def one_round(workers: int, text: str, tree: Path | None = None) -> tuple[float, float]:
    """(flights per minute of the whole command, mean wall seconds per flight on a worker), with this tree's code
    or the checkout `tree`'s."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "bench.toml"
        path.write_text(text)
        started = time.perf_counter()
        run_in([sys.executable, "-m", "ground_tools", "campaign", str(path), "--out", str(Path(folder) / "out"),
                "--workers", str(workers), "--no-progress"], tree, check=True, capture_output=True,
               timeout=3600)  # fmt: skip
        elapsed = time.perf_counter() - started
        with duckdb.connect(str(Path(folder) / "out" / "campaign.duckdb"), read_only=True) as db:
            count, done, wall = db.execute(
                "SELECT count(*), count_if(status = 'done'), avg(wall_s) FROM flights"
            ).fetchone()
    if done != count:
        raise SystemExit(f"{count - done} flight(s) failed")
    return count / elapsed * 60.0, wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--flights", type=int, default=8)
    parser.add_argument("--duration", type=float, default=3.0, help="simulated seconds of each flight's profile")
    parser.add_argument("--controller", choices=("mpc", "pid"), default="mpc")
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the figures to FILE (JSON)")
    parser.add_argument("--baseline", type=Path, metavar="DIR", help="also run a checkout of another commit")
    args = parser.parse_args()
    text = campaign_text(args.flights, args.duration, args.controller)
    if args.baseline is not None:
        against_baseline(args, text)
        return
    rates = {}
    for workers in (1, 2):
        rounds = [one_round(workers, text) for _ in range(args.repeats)]
        rates[workers] = statistics.median(rate for rate, _ in rounds)
        wall = statistics.median(w for _, w in rounds)
        print(
            f"{workers} worker(s): {rates[workers]:.2f} flights/min ({args.flights} flights of {args.duration:g} s, "
            f"{args.controller}; {wall:.1f} s per flight on a worker; median of {args.repeats})",
            flush=True,
        )
    print(f"scaling 1 -> 2 workers: {rates[2] / rates[1]:.2f}x")
    if args.json:
        figures = {"flights": args.flights, "duration_s": args.duration, "controller": args.controller,
                   "flights_per_minute": {str(workers): rate for workers, rate in rates.items()}}  # fmt: skip
        args.json.write_text(json.dumps(figures, indent=1) + "\n")


def against_baseline(args: argparse.Namespace, text: str) -> None:
    """Flights per minute on 1 and 2 workers, this tree and the baseline alternately, `args.repeats` rounds."""
    for workers in (1, 2):
        here: list[float] = []
        there: list[float] = []
        for round_index in range(args.repeats):
            sides = [(here, None), (there, args.baseline)]
            for rates, tree in sides[::-1] if round_index % 2 else sides:
                rates.append(one_round(workers, text, tree)[0])
        label = f"{workers} worker(s), flights/min ({args.flights} flights of {args.duration:g} s, {args.controller})"
        print(ratio_summary(label, here, there, "higher"), flush=True)


if __name__ == "__main__":
    main()
