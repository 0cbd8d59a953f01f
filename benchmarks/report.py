"""The figures page, docs/figures.md: the benchmarks run with short options, every measured figure the guides refer
to on one page, with the date, the machine and the commit; and the experiments' figures (docs/images/) redrawn
from the same runs.

    python benchmarks/report.py [--page docs/figures.md] [--images docs/images]

Each benchmark runs as a user would run it (`python benchmarks/bench_*.py ... --json FILE`), one after the other,
so they do not share the cores; about 5 minutes on 2 cores. The page says how to run the longer versions.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from transport.udp import usable_cpus

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

SCENARIOS = ("accel", "accel-decel", "circle", "servo-failure", "motor-failure")
# The experiments' figures the guides show: (scenario, the run folder's figure) -> docs/images/<scenario>_<figure>.
IMAGES = (("accel", "tilt_pitch"), ("accel-decel", "tilt_pitch"), ("circle", "roll_yaw"),
          ("servo-failure", "velocity"), ("motor-failure", "actuators"))  # fmt: skip


@dataclass(frozen=True)
class Benchmark:
    name: str
    script: str
    arguments: tuple[str, ...]


def benchmarks(runs: Path) -> tuple[Benchmark, ...]:
    """The short runs, in order; `runs`: where the experiments' run folders go."""
    return (
        Benchmark("scenarios", "bench_scenarios.py", ("--out", str(runs))),
        Benchmark("mpc", "bench_mpc.py", ("--seconds", "10", "--ipopt-samples", "3", "--horizons", "")),
        Benchmark("sitl", "bench_sitl.py", ("--repeats", "1")),
        Benchmark("breakdown", "bench_sitl_breakdown.py", ("--duration", "5", "--overlap", "0")),
        Benchmark("plant", "bench_plant.py", ("--seconds", "5", "--repeats", "1")),
        Benchmark("allocation", "bench_allocation.py", ("--solves", "2000")),
        Benchmark("api", "bench_api.py", ("--runs", "3")),
        Benchmark("campaign", "bench_campaign.py", ("--flights", "4", "--duration", "3")),
    )


# ---- the page, pure -----------------------------------------------------------------------------------------------
def fixed(value: float | None, digits: int = 2) -> str:
    return "–" if value is None else f"{value:.{digits}f}"


def table(header: tuple[str, ...], rows: list[tuple[str, ...]]) -> list[str]:
    return [
        "| " + " | ".join(header) + " |",
        "| " + " | ".join("---" for _ in header) + " |",
        *("| " + " | ".join(row) + " |" for row in rows),
        "",
    ]


# metric key -> (label, digits), in the order of the table; scenario-specific ones are blank where null
METRICS: tuple[tuple[str, str, int], ...] = (
    ("survived", "survived", -1),
    ("vx_rmse", "v_x RMS error (m/s)", 2),
    ("vy_rmse", "v_y RMS error (m/s)", 2),
    ("vz_rmse", "v_z RMS error (m/s)", 2),
    ("vz_max_abs", "max abs v_z (m/s)", 2),
    ("pitch_max_abs_deg", "max abs pitch (deg)", 1),
    ("roll_max_abs_deg", "max abs roll (deg)", 1),
    ("heading_error_max_deg", "max heading off the course (deg)", 1),
    ("alt_change_max_m", "max altitude change (m)", 2),
    ("t_reach_s", "time to reach the top speed (s)", 1),
    ("tilt_tv_ratio", "tilt total variation / range", 2),
    ("mode_switches", "mode switches", 0),
    ("final_speed", "final speed (m/s)", 2),
    ("radial_rmse_m", "radial RMS error (m)", 2),
    ("radial_max_m", "radial max error (m)", 2),
    ("bank_mean_deg", "mean bank in the turn (deg)", 1),
    ("failure_t_s", "failure injected at (s)", 2),
    ("vx_rmse_after_failure", "v_x RMS error after the failure (m/s)", 2),
    ("alt_loss_max_m", "max altitude loss (m)", 2),
    ("solve_ms_median", "MPC solve median (ms)", 2),
    ("solve_ms_p99", "MPC solve p99 (ms)", 2),
    ("solves_failed", "MPC solves failed", 0),
)


def piece_label(label: str) -> str:
    """A breakdown piece's label with its nesting (two leading spaces a level) shown in a table cell."""
    depth = (len(label) - len(label.lstrip(" "))) // 2
    return "· " * depth + label.strip()


def metric_cell(value: Any, digits: int) -> str:
    if value is None:
        return ""
    if digits < 0:
        return "yes" if value else "**no**"
    return f"{value:.{digits}f}"


def metrics_rows(runs: Mapping[str, Mapping[str, Any]]) -> list[tuple[str, ...]]:
    rows = []
    for key, label, digits in METRICS:
        cells = []
        for scenario in SCENARIOS:
            by = runs.get(scenario, {})
            pair = [metric_cell(by[c]["metrics"].get(key), digits) if c in by else "" for c in ("mpc", "pid")]
            cells.append(" / ".join(pair) if any(pair) else "")
        if any(cells):
            rows.append((label, *cells))
    return rows


def page(figures: Mapping[str, Any], stamp: Mapping[str, str]) -> str:
    scenarios, mpc, sitl, breakdown = figures["scenarios"], figures["mpc"], figures["sitl"], figures["breakdown"]
    plant, allocation, api, campaign = figures["plant"], figures["allocation"], figures["api"], figures["campaign"]
    run_rows = [
        (
            scenario,
            controller.upper(),
            fixed(run["sim_s"], 1),
            fixed(run["wall_s"], 1),
            fixed(run["real_time_factor"], 1),
        )
        for scenario in SCENARIOS
        for controller, run in scenarios["runs"].get(scenario, {}).items()
    ]
    check_rows = [(check["scenario"], check["check"], "pass" if check["passed"] else "**FAIL**")
                  for check in scenarios["checks"]]  # fmt: skip
    sitl_rows = [(label, fixed(run["real_time_factor"], 1), fixed(run["wall_us_per_step"], 0),
                  fixed(run["autopilot_us_per_step"], 0), fixed(run["plant_us_per_step"], 0))
                 for label, run in sitl["configurations"].items()]  # fmt: skip
    breakdown_rows = [(piece_label(piece["piece"]), fixed(piece["calls_per_s"], 0) if piece["calls_per_s"] >= 1 else "",
                       fixed(piece["ms_per_s"], 1))
                      for piece in breakdown["pieces"]]  # fmt: skip
    component_rows = [(name.removesuffix("_us").replace("_", " "), fixed(value, 1))
                      for name, value in plant["component_us"].items()]  # fmt: skip
    rates = campaign["flights_per_minute"]
    lines = [
        "<!-- Written by `python benchmarks/report.py`: run it again rather than editing this page. -->",
        "",
        "# Figures",
        "",
        "Every measured figure the guides refer to, from one run of `python benchmarks/report.py` "
        f"on {stamp['date']}, on {stamp['machine']} (load average {stamp['load']} when it began), at commit "
        f"{stamp['commit']}. The benchmarks ran one after the "
        "other with short options (below); wall-clock figures move with the machine and its load, the flights' "
        "metrics do not (the lockstep flights repeat to the last digit, the solve times aside).",
        "",
        "## The paper's experiments",
        "",
        f"`vtol scenario all --controller both` (ten runs, two at a time): **{scenarios['wall_s']:.0f} s** of wall "
        "time. `vtol scenario accel` alone, one run at a time: "
        + ", ".join(f"{c.upper()} {fixed(f, 1)}x real time" for c, f in scenarios["alone"].items())
        + ".",
        "",
        *table(("scenario", "controller", "simulated s", "wall s", "x real time"), run_rows),
        "### Metrics, MPC / PID",
        "",
        "What each metric means: [The paper's experiments](scenarios.md#metrics).",
        "",
        *table(("metric", *SCENARIOS), metrics_rows(scenarios["runs"])),
        "### The MPC's acceptance checks",
        "",
        *table(("scenario", "check", "result"), check_rows),
        f"PID runs that do not survive: {', '.join(scenarios['pid_failed']) or 'none'}.",
        "",
        "## The MPC solve",
        "",
        f"`bench_mpc.py`: the acceleration profile in closed loop for {mpc['seconds']:g} s in one process (plant "
        f"physics and the flight controller, no sockets), one real-time iteration per 100 Hz tick: {mpc['solves']} "
        f"solves, {mpc['solves_failed']} failed.",
        "",
        *table(
            ("solver", "median (ms)", "p99 (ms)", "max (ms)"),
            [
                ("RTI, the paper's horizon (25 x 10 ms)", fixed(mpc["rti_ms_median"], 3),
                 fixed(mpc["rti_ms_p99"], 3), fixed(mpc["rti_ms_max"], 3)),
                ("RTI, the long horizon (2.05 s)", fixed(mpc["long_ms_median"], 3), "", ""),
                ("IPOPT to convergence, NLP built once", fixed(mpc.get("ipopt_built_once_ms_median"), 1), "", ""),
                ("IPOPT, NLP rebuilt every call (the paper's way)", fixed(mpc.get("ipopt_rebuilt_ms_median"), 1), "", ""),
            ],
        ),  # fmt: skip
        "## The whole SITL",
        "",
        f"`bench_sitl.py`: `vtol-sim` and `vtol-autopilot` in lockstep flying the {sitl['profile']} profile "
        f"({sitl['seconds']:g} s simulated) from the autopilot's own set-points, no ground station; each process's "
        "own work per 2.5 ms physics step (the rest of the wall time is the two waiting for each other).",
        "",
        *table(("configuration", "x real time", "wall µs / step", "autopilot µs / step", "plant µs / step"),
               sitl_rows),  # fmt: skip
        "### Where a simulated second goes",
        "",
        f"`bench_sitl_breakdown.py`: the same lockstep pair, the {breakdown['controller'].upper()} solving "
        f"{'one tick ahead' if breakdown['overlap'] else 'synchronously'}, {breakdown['seconds']:g} s of the "
        f"{breakdown['profile']} profile: {fixed(breakdown['real_time_factor'], 1)}x real time. Per simulated "
        f"second, {fixed(breakdown['wall_ms_per_s'], 0)} ms of wall time: the autopilot's work "
        f"{fixed(breakdown['autopilot_ms_per_s'], 0)} ms, the plant's {fixed(breakdown['plant_ms_per_s'], 0)} ms "
        "(its pieces: [the plant](#the-plant)). The autopilot's pieces, measured under cProfile and scaled to its "
        "unprofiled work (a piece's time includes the pieces under it):",
        "",
        *table(("piece", "calls / simulated s", "ms / simulated s"), breakdown_rows),
        "## The plant",
        "",
        f"`bench_plant.py`: `vtol-sim` in lockstep against the smallest correct autopilot (an echo): "
        f"{fixed(plant['lockstep_real_time_factor'], 1)}x real time, "
        f"{fixed(plant['wall_us_per_step'], 0)} µs of wall time per step; the plant's own work alone "
        f"{fixed(plant['plant_alone_real_time_factor'], 1)}x real time. Its pieces (µs, median):",
        "",
        *table(("piece", "µs"), component_rows),
        "## The allocation",
        "",
        f"`bench_allocation.py`: {allocation['solves']} allocations along a forward transition (a rotor failing "
        f"for the last fifth): `allocate()` median {fixed(allocation['allocate_us_median'], 1)} µs, p99 "
        f"{fixed(allocation['allocate_us_p99'], 1)} µs, {allocation['fallbacks']} fall-backs.",
        "",
        "## The Python API",
        "",
        f"`bench_api.py`: `Vehicle(controller=\"{api['controller']}\")` from the call to ready to arm (HEARTBEAT "
        f"past BOOT, HOME_POSITION, SYS_STATUS's pre-arm check): median {fixed(api['ready_s_median'])} s, max "
        f"{fixed(api['ready_s_max'])} s over {api['starts']} starts.",
        "",
        "## Campaigns",
        "",
        f"`bench_campaign.py`: a campaign of {campaign['flights']} `servo-failure` flights of "
        f"{campaign['duration_s']:g} s ({campaign['controller'].upper()}), the whole `vtol campaign` command: "
        f"{fixed(rates['1'])} flights a minute on one worker, {fixed(rates['2'])} on two.",
        "",
        "## Running the benchmarks",
        "",
        "This page: `python benchmarks/report.py` (about 5 minutes on 2 cores). It runs, one after the other:",
        "",
        *(f"- `python {shlex.join([f'benchmarks/{b.script}', *b.arguments])}`" for b in benchmarks(Path("runs"))),
        "",
        "Each prints more than this page shows. Their defaults are longer runs, closer to a quiet machine's figures:",
        "`bench_mpc.py` (25 s, 20 IPOPT samples, horizon scaling; `--levers` replays the run through each solver "
        "variant), `bench_sitl.py` (3 rounds), `bench_api.py --hover 60` (how many vehicles hover together at real "
        "time), `bench_campaign.py` (8 flights, `--repeats`). Others measure what this page does not: "
        "`bench_soak.py` (hours of hovering: memory and step time), `bench_ulog.py` (what the ULog logger adds), `bench_faults.py` (the fault campaign at full "
        "size), `bench_busy.py` (an interactive flight beside a lockstep one; `bench_sitl_breakdown.py --controller "
        "pid` or `--overlap 1` breaks down the other configurations), `bench_horizon.py` and `bench_braking_bound.py` (the long "
        "horizon's screening), `bench_engines.py` (Dask against Ray), `mavsdk_examples.py` (MAVSDK-Python's "
        "examples against `vtol up`), `compare_runs.py` (two `vtol scenario` folders, metric by metric and their "
        "time series byte for byte), `bench_control_path.py` (the flight controller's CPU time per simulated second "
        "in a one-process closed loop, with fingerprints of its commands); `bench_sitl.py`, `bench_scenarios.py` "
        "and `bench_control_path.py` take `--baseline DIR` to fly a checkout of another commit round by round "
        "beside this one.",
        "",
    ]  # fmt: skip
    return "\n".join(lines)


# ---- the runs and the machine -------------------------------------------------------------------------------------
def run_benchmark(benchmark: Benchmark, scratch: Path, say: Callable[[str], None]) -> dict[str, Any]:
    output = scratch / f"{benchmark.name}.json"
    argv = [sys.executable, str(HERE / benchmark.script), *benchmark.arguments, "--json", str(output)]
    say(f"report: {' '.join(argv[1:])}")
    started = time.monotonic()
    completed = subprocess.run(argv, cwd=ROOT, capture_output=True, text=True)
    if completed.returncode != 0 or not output.is_file():
        raise SystemExit(f"report: {benchmark.script} failed (exit code {completed.returncode}):\n"
                         f"{completed.stdout[-3000:]}\n{completed.stderr[-3000:]}")  # fmt: skip
    say(f"report: {benchmark.script} done in {time.monotonic() - started:.0f} s")
    return json.loads(output.read_text())


def machine() -> str:
    model = next((line.split(":", 1)[1].strip() for line in _read_lines(Path("/proc/cpuinfo"))
                  if line.startswith("model name")), platform.processor() or platform.machine())  # fmt: skip
    return (
        f"{model}, {usable_cpus()} CPU(s), {platform.system()} {platform.release()}, Python {platform.python_version()}"
    )


def _read_lines(path: Path) -> list[str]:
    try:
        return path.read_text().splitlines()
    except OSError:
        return []


def commit() -> str:
    def git(*arguments: str) -> str:
        return subprocess.run(["git", *arguments], cwd=ROOT, capture_output=True, text=True, check=True).stdout.strip()

    try:
        head = git("rev-parse", "--short=12", "HEAD")
        changed = [line for line in git("status", "--porcelain").splitlines()
                   if not line[3:].startswith(("docs/figures.md", "docs/images/"))]  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        return "unknown (not a git checkout)"
    return f"`{head}`" + (" with uncommitted changes" if changed else "")


def copy_images(runs: Path, images: Path) -> None:
    images.mkdir(parents=True, exist_ok=True)
    for scenario, figure in IMAGES:
        shutil.copyfile(runs / scenario / "mpc" / f"{figure}.png", images / f"{scenario}_{figure}.png")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--page", type=Path, default=ROOT / "docs" / "figures.md")
    parser.add_argument("--images", type=Path, default=ROOT / "docs" / "images")
    args = parser.parse_args(argv)
    stamp = {"date": datetime.now(UTC).strftime("%Y-%m-%d"), "machine": machine(), "commit": commit(),
             "load": " / ".join(f"{load:.1f}" for load in os.getloadavg())}  # fmt: skip
    with tempfile.TemporaryDirectory(prefix="report-") as folder:
        scratch = Path(folder)
        runs = scratch / "runs"
        figures = {b.name: run_benchmark(b, scratch, lambda text: print(text, flush=True)) for b in benchmarks(runs)}
        copy_images(runs, args.images)
    args.page.write_text(page(figures, stamp))
    print(f"report: wrote {args.page} and the experiments' figures in {args.images}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
