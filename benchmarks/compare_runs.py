"""Compare the metrics of two `vtol scenario` output folders, run by run, to the last digit.

    python benchmarks/compare_runs.py BEFORE_DIR AFTER_DIR

For a refactor that must not change a flight: every metric of every <scenario>/<controller>/metrics.json in both
folders is compared exactly, except the MPC's solve times (a measurement of the machine, not of the flight), and
the runs' timeseries.csv byte for byte where both have one. Prints one line per run and exits 1 if any metric or
time series differs or a run is missing on one side.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ground_tools.scenario_run import WALL_CLOCK_KEYS


def metric_differences(before: dict, after: dict) -> dict[str, tuple]:
    keys = (set(before) | set(after)) - set(WALL_CLOCK_KEYS)
    return {key: (before.get(key), after.get(key)) for key in sorted(keys) if before.get(key) != after.get(key)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", type=Path)
    parser.add_argument("after", type=Path)
    args = parser.parse_args()
    runs = sorted({p.parent.relative_to(root) for root in (args.before, args.after)
                   for p in root.glob("*/*/metrics.json")})  # fmt: skip
    same = 0
    for run in runs:
        paths = [root / run / "metrics.json" for root in (args.before, args.after)]
        if not all(path.is_file() for path in paths):
            print(f"{run}: missing in {' and '.join(str(p.parent) for p in paths if not p.is_file())}")
            continue
        differences = metric_differences(*(json.loads(path.read_text()) for path in paths))
        series = [path.with_name("timeseries.csv") for path in paths]
        series_differ = all(path.is_file() for path in series) and series[0].read_bytes() != series[1].read_bytes()
        if differences:
            print(f"{run}: {len(differences)} metric(s) differ: {differences}")
        elif series_differ:
            print(f"{run}: metrics identical, timeseries.csv differs")
        else:
            same += 1
            print(f"{run}: identical ({len(json.loads(paths[0].read_text()))} metrics, solve times aside"
                  f"{', and the time series' if all(path.is_file() for path in series) else ''})")  # fmt: skip
    print(f"{same} of {len(runs)} runs identical")
    return 0 if same == len(runs) and runs else 1


if __name__ == "__main__":
    sys.exit(main())
