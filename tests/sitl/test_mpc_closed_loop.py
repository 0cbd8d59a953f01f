"""The unified MPC flying the paper's profiles with the real plant in lockstep (issue 5 "Done means")."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ground_tools.scenario_run import run_scenario
from scenarios.variants import build_scenario
from tests.sitl.sitl import fly
from transport.flight_log import read_flight_log


def velocity_rms_error(flight, axis: str) -> float:
    return float(np.sqrt(np.mean((flight.log[axis] - flight.log[axis + "_sp"]) ** 2)))


def command_chatter(flight, start: float, end: float) -> float:
    """RMS of the sample-to-sample change of the allocated commands u1..u8 (thrust fractions, deflections) over
    the 100 Hz log rows in [start, end]: a smooth command moves ~1e-4 per row, chatter ~1e-2 (docs/autopilot.md
    1.6)."""
    rows = flight.between(start, end)
    commands = np.column_stack([rows[f"u{i}"] for i in range(1, 9)])
    return float(np.sqrt(np.mean(np.diff(commands, axis=0) ** 2)))


@pytest.fixture(scope="module")
def accel_flights(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("accel")
    return {controller: fly(tmp, "accel", 25.0, controller=controller) for controller in ("mpc", "pid")}


def test_mpc_accelerates_to_cruise_smoothly_within_the_limits(accel_flights):
    flight = accel_flights["mpc"]
    assert flight.at(16.0)["vn"] == pytest.approx(27.74, abs=0.5)
    assert np.abs(flight.log["vd"]).max() <= 1.0
    assert np.abs(np.degrees(flight.log["pitch"])).max() <= 20.0
    assert np.abs(-flight.log["down"] - 100.0).max() <= 3.0
    mean_tilt = np.degrees(np.mean([flight.log[f"tilt_est{i}"] for i in range(1, 5)], axis=0))
    assert mean_tilt[0] == pytest.approx(0.0, abs=1.0) and mean_tilt.max() >= 80.0
    # Smooth: no step anywhere (the servo slews at most 60 deg/s: 0.6 deg per 10 ms log row; allow 1 deg).
    assert np.abs(np.diff(mean_tilt)).max() < 1.0
    assert set(flight.modes) == {"MPC"} and flight.autopilot["mode_switches"] == 0
    assert flight.autopilot["allocation_fallbacks"] == 0
    solver = flight.autopilot["controller"]
    assert solver["solves_failed"] == 0 and not solver["fell_back_to_pid"]


def test_mpc_commands_are_smooth_in_the_steady_turn(tmp_path):
    """The circle at 26 m/s, rotors near 90 deg: the attitude holds, and so must the commands (before the velocity
    estimate rotors 3/4 and the ailerons jumped by ~0.1 between consecutive rows: chatter 2.0e-2; now 5e-4)."""
    flight = fly(tmp_path, "circle", 40.0, controller="mpc")
    assert command_chatter(flight, 20.0, 40.0) < 3e-3
    turn = flight.between(20.0, 40.0)
    expected_bank = math.degrees(math.atan(26.0**2 / (9.80665 * 250.0)))  # 15.4 deg
    assert np.degrees(turn["roll"]).mean() == pytest.approx(expected_bank, abs=1.0)
    assert np.abs(np.hypot(turn["vn"], turn["ve"]) - 26.0).max() < 0.5
    assert flight.autopilot["allocation_fallbacks"] == 0


def test_mpc_decelerates_back_to_hover_tilting_the_rotors_back(tmp_path):
    flight = fly(tmp_path, "accel-decel", 32.0, controller="mpc")
    assert flight.log["vn"].max() > 20.0
    end = flight.between(31.0)
    assert np.abs(end["vn"]).max() < 0.5 and np.abs(end["vd"]).max() < 0.2
    braking = flight.between(15.0, 26.0)
    assert np.degrees(braking["tilt_est1"]).min() < 0.0  # rotors tilted back past 0 deg while braking
    assert np.abs(-flight.log["down"] - 100.0).max() < 5.0
    # The MPC flies it to the end: no failed solve, no PID back-up, pitch inside the soft 45 deg bound
    # (docs/mpc.md, deviation 6; before it, 3 failed solves at 22.3 s and 47 deg).
    solver = flight.autopilot["controller"]
    assert solver["solves_failed"] == 0 and not solver["fell_back_to_pid"]
    assert set(flight.modes) == {"MPC"}
    assert np.degrees(np.abs(flight.log["pitch"])).max() < 42.0  # measured 39.0


def test_the_long_horizon_brakes_with_the_set_point(tmp_path):
    """--mpc-horizon long (docs/design/alternatives.md, the long horizon), through MAVLink as `vtol scenario` flies it: the first 5 s of the
    braking, where the paper's 0.25 s horizon falls 7.5 m/s behind, tracked within a few m/s and without a failed
    solve. (From a hover spawn with the internal profile it splits the front and rear tilts in cruise and the PID
    takes over in the braking: docs/design/alternatives.md, the long horizon.)"""
    result = run_scenario(build_scenario("accel-decel", {"duration_s": 20.0}), "mpc", tmp_path, record=False,
                          mpc_horizon="long")  # fmt: skip
    log = read_flight_log(result.run_dir / "timeseries.csv").columns
    braking = (log["t"] >= 15.0) & (log["t"] <= 20.0)
    assert np.abs(log["vn"][braking] - log["vn_sp"][braking]).max() < 3.0  # measured 1.98
    assert np.abs(log["vd"]).max() < 1.0  # measured 0.65
    assert np.degrees(np.abs(log["pitch"])).max() < 25.0  # measured 17.2
    assert result.metrics["solves_failed"] == 0


def test_both_controllers_command_smoothly_in_cruise(accel_flights):
    # Measured 2.6e-3 (MPC) and 1.0e-3 (PID) on the raw cm/s velocity, 2.6e-4 for both on the estimate.
    for controller in ("mpc", "pid"):
        assert command_chatter(accel_flights[controller], 15.0, 25.0) < 8e-4, controller


def test_mpc_beats_the_pid_baseline_on_the_acceleration_test(accel_flights):
    mpc, pid = accel_flights["mpc"], accel_flights["pid"]
    assert velocity_rms_error(mpc, "vn") < velocity_rms_error(pid, "vn")
    assert np.abs(mpc.log["vd"]).max() < np.abs(pid.log["vd"]).max()
    assert np.abs(mpc.log["pitch"]).max() < np.abs(pid.log["pitch"]).max()
