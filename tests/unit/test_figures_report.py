"""The figures page's text (benchmarks/report.py): every section the guides link to, the experiments' metrics MPC
against PID, and the command lines that make it, from the benchmarks' JSON figures alone."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

from markdown.extensions.toc import slugify

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("figures_report", ROOT / "benchmarks" / "report.py")
report = sys.modules["figures_report"] = importlib.util.module_from_spec(_spec)  # benchmarks/ is not a package
_spec.loader.exec_module(report)

METRICS = {"survived": True, "vx_rmse": 0.216, "solve_ms_median": 0.4, "radial_rmse_m": None}
FIGURES = {
    "scenarios": {
        "wall_s": 150.0,
        "alone": {"mpc": 2.9, "pid": 4.2},
        "runs": {"accel": {"mpc": {"sim_s": 26.0, "wall_s": 10.0, "real_time_factor": 2.6, "metrics": METRICS},
                           "pid": {"sim_s": 26.0, "wall_s": 6.0, "real_time_factor": 4.3,
                                   "metrics": METRICS | {"survived": False, "solve_ms_median": None}}}},
        "checks": [{"scenario": "accel", "check": "survives", "passed": True}],
        "pid_failed": ["accel"],
    },
    "mpc": {"seconds": 10, "solves": 1000, "solves_failed": 0, "rti_ms_median": 0.36, "rti_ms_p99": 0.9,
            "rti_ms_max": 2.0, "long_ms_median": 1.4, "ipopt_built_once_ms_median": 170.0},
    "sitl": {"profile": "accel", "seconds": 25, "configurations": {
        "pid": {"real_time_factor": 5.0, "wall_us_per_step": 500, "autopilot_us_per_step": 160,
                "plant_us_per_step": 80}}},
    "breakdown": {"profile": "accel", "seconds": 5, "controller": "mpc", "overlap": 0, "real_time_factor": 7.2,
                  "wall_ms_per_s": 139, "autopilot_ms_per_s": 118, "plant_ms_per_s": 19, "pieces": [
        {"piece": "autopilot loop (PlantLoop.run)", "calls_per_s": 0, "ms_per_s": 134.1},
        {"piece": "    MPC tick, synchronous (MpcVelocityController.update)", "calls_per_s": 100, "ms_per_s": 43.3}]},
    "plant": {"component_us": {"rk4_step_us": 2.2}, "lockstep_real_time_factor": 5.7, "wall_us_per_step": 440,
              "plant_alone_real_time_factor": 24.6},
    "allocation": {"solves": 2000, "allocate_us_median": 25.0, "allocate_us_p99": 60.0, "fallbacks": 0},
    "api": {"controller": "mpc", "starts": 3, "ready_s_median": 1.1, "ready_s_max": 1.4},
    "campaign": {"flights": 4, "duration_s": 3, "controller": "mpc", "flights_per_minute": {"1": 8.5, "2": 9.9}},
}  # fmt: skip
STAMP = {"date": "today", "machine": "a machine", "commit": "`abc`", "load": "0.1 / 0.2 / 0.3"}


def test_the_page_has_every_section_the_guides_link_to():
    page = report.page(FIGURES, STAMP)
    sections = {slugify(line.lstrip("#").strip(), "-") for line in page.splitlines() if line.startswith("#")}
    assert {
        "the-papers-experiments",
        "the-mpc-solve",
        "the-whole-sitl",
        "where-a-simulated-second-goes",
        "the-python-api",
        "campaigns",
    } <= sections
    assert "| · · MPC tick, synchronous (MpcVelocityController.update) | 100 | 43.3 |" in page


def test_the_metrics_are_mpc_against_pid_and_a_lost_run_stands_out():
    page = report.page(FIGURES, STAMP)
    assert "| survived | yes / **no** |" in page
    assert "| v_x RMS error (m/s) | 0.22 / 0.22 |" in page
    assert "| MPC solve median (ms) | 0.40 /  |" in page
    assert "radial RMS error" not in page  # null for every run: no row
    assert "PID runs that do not survive: accel." in page


def test_the_page_says_when_where_and_how_it_was_made():
    page = report.page(FIGURES, STAMP)
    assert "on today, on a machine (load average 0.1 / 0.2 / 0.3 when it began), at commit `abc`" in page
    assert "- `python benchmarks/bench_mpc.py --seconds 10 --ipopt-samples 3 --horizons ''`" in page
