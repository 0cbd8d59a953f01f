"""`vtol fly`: both processes in lockstep, a profile flown end to end with the MPC (the default), log and figures
written, its progress read from the vehicle's telemetry."""

from __future__ import annotations

import json
import os
import subprocess
import sys

from ground_tools.lockstep_flight import fly_lockstep

VTOL = os.path.join(os.path.dirname(sys.executable), "vtol")


def test_vtol_fly_writes_log_summary_and_figures(tmp_path):
    result = subprocess.run([VTOL, "fly", "accel", "--duration", "3", "--out", str(tmp_path)],
                            capture_output=True, text=True, timeout=300)  # fmt: skip
    assert result.returncode == 0, result.stderr
    run = tmp_path / "accel" / "mpc"
    for name in ("flight.csv", "velocity.png", "tilt_pitch.png", "roll_yaw.png", "actuators.png", "ground_track.png"):
        assert (run / name).stat().st_size > 1000, name
    summary = json.loads((run / "summary.json").read_text())
    assert summary["plant"]["sim_time_s"] == 3.0 and summary["plant"]["missed_commands"] == 0
    assert "solve_ms_median" in summary["autopilot"]["controller"]  # the MPC flew it
    assert "figure" in result.stdout


def test_a_lockstep_flight_reports_its_progress_in_simulated_seconds() -> None:
    progress: list[float] = []
    flight = fly_lockstep("hover", 4.0, controller="pid", on_progress=progress.append)
    assert flight.plant["sim_time_s"] == 4.0
    assert progress == sorted(progress) and 0.0 < progress[-1] <= 4.0 + 0.1
    assert len(set(progress)) >= 2  # it moved on between reports


def test_a_duration_between_plant_steps_still_ends_the_flight(tmp_path):
    """1.0011 s is not a whole number of 2.5 ms steps (the plant rounds it down to 400): both processes must still stop together."""
    result = subprocess.run([VTOL, "fly", "hover", "--duration", "1.0011", "--out", str(tmp_path)],
                            capture_output=True, text=True, timeout=120)  # fmt: skip
    assert result.returncode == 0, result.stderr


def test_vtol_bad_arguments_give_one_line_and_exit_2():
    for args in (["fly", "loop-the-loop"], ["fly", "accel", "--duration", "0"], []):
        result = subprocess.run([VTOL, *args], capture_output=True, text=True, timeout=60)
        assert result.returncode == 2
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("vtol")
