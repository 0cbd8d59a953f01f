"""The scenario metrics (docs/scenarios.md) on synthetic flights whose answers are known by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ground_tools.metrics import (
    detection_time,
    flight_metrics,
    heading_error_max_deg,
    mode_switches,
    tilt_tv_ratio,
    time_to_reach,
)
from scenarios.experiments import Circle


def synthetic_log(n: int = 1001, dt: float = 0.01) -> dict[str, np.ndarray]:
    t = np.arange(n) * dt
    zeros = np.zeros(n)
    log = {name: zeros.copy() for name in ("north", "east", "vn", "ve", "vd", "vn_sp", "ve_sp", "vd_sp", "roll",
                                           "pitch", "yaw")}  # fmt: skip
    log["t"] = t
    log["down"] = np.full(n, -100.0)
    for i in range(1, 5):
        log[f"tilt_est{i}"] = zeros.copy()
    return log


def test_velocity_errors_extremes_and_survival_by_hand():
    log = synthetic_log()
    log["vn_sp"][:] = 10.0
    log["vn"][:] = 9.0  # 1 m/s behind throughout
    log["vd"][500] = -2.0
    log["pitch"][300] = math.radians(-30)
    log["down"][700] = -95.0  # 5 m lower once
    metrics = flight_metrics(log, ["MPC"] * len(log["t"]))
    assert metrics["vx_rmse"] == pytest.approx(1.0)
    assert metrics["vz_rmse"] == pytest.approx(2.0 / math.sqrt(1001))
    assert (metrics["vz_max_abs"], metrics["pitch_max_abs_deg"]) == (2.0, pytest.approx(30.0))
    assert metrics["alt_change_max_m"] == pytest.approx(5.0)
    assert metrics["t_reach_s"] is None  # never within 0.5 m/s of 10
    assert metrics["survived"] is True and metrics["radial_rmse_m"] is None and metrics["solves_failed"] is None
    log["roll"][10] = math.radians(61)
    assert flight_metrics(log, ["MPC"] * len(log["t"]))["survived"] is False


def test_heading_error_from_the_set_points_course_by_hand():
    log = synthetic_log()
    assert flight_metrics(log, ["MPC"] * len(log["t"]))["heading_error_max_deg"] is None  # never 1 m/s
    log["vn_sp"][100:] = -5.0  # course 180 deg: a yaw of -170 deg is 10 deg off it, not 350
    log["yaw"][:] = math.radians(-170)
    log["yaw"][:100] = math.radians(90.0)  # standing still (no course): not counted
    assert flight_metrics(log, ["MPC"] * len(log["t"]))["heading_error_max_deg"] == pytest.approx(10.0)
    # A course to the east, the nose 60 deg off it to the north-east and then across it to the south-west.
    yaw = np.radians([30.0, 90.0, 210.0])
    assert heading_error_max_deg(yaw, np.zeros(3), np.full(3, 2.0)) == pytest.approx(120.0)
    assert heading_error_max_deg(yaw, np.zeros(3), np.array([2.0, 2.0, 0.5])) == pytest.approx(60.0)


def test_time_to_reach_tilt_smoothness_and_mode_switches():
    t = np.arange(0, 10, 0.01)
    assert time_to_reach(t, 2 * t, 10.0) == pytest.approx(4.75)
    assert tilt_tv_ratio(np.linspace(0, 90, 100)) == pytest.approx(1.0)  # smooth and monotonic
    assert tilt_tv_ratio(np.array([0, 90, -7, 0])) == pytest.approx((90 + 97 + 7) / 97)  # swings back
    assert mode_switches(["MC", "MC", "TRANSITION_FW", "FW", "FW", "TRANSITION_MC", "MC"]) == 4


def test_radial_error_about_the_intended_circle():
    log = synthetic_log(n=3000)
    radius, start = 250.0, 5.0
    t = log["t"]
    angle = np.clip(t - start, 0, None) * 0.1
    # Clockwise from above, starting heading north at (north 100, east 0): centre at (100, 250).
    log["north"] = 100 + radius * np.sin(angle) + np.where(t >= start, 2.0 * np.sin(angle), 0.0)
    log["east"] = radius - radius * np.cos(angle)
    metrics = flight_metrics(log, ["MPC"] * len(t), solver={"solve_ms_median": 1.2, "solves_failed": 0},
                             circle=Circle(start, radius))  # fmt: skip
    assert 0 < metrics["radial_rmse_m"] <= 2.0 and metrics["radial_max_m"] <= 2.0 + 1e-9
    assert metrics["solve_ms_median"] == 1.2 and metrics["solves_failed"] == 0


def test_detection_time_is_the_first_finding_at_or_after_the_injection():
    texts = [(1.0, "Tilt servo 1 jam detected"), (2.0, "Failure injected: motor 1 OFF"), (2.0, "plant: rotor 1: OFF"),
             (2.3, "Takeoff detected"), (2.5, "Motor failure detected"), (3.0, "Motor failure detected")]  # fmt: skip
    assert detection_time(texts, 2.0) == 2.5  # not the finding before the injection, not "Takeoff detected"
    assert detection_time(texts, 3.5) is None and detection_time(texts, None) is None
    log = synthetic_log()
    modes = ["MPC"] * len(log["t"])
    assert flight_metrics(log, modes, failure_s=2.0, detected_s=2.5)["detected_after_s"] == pytest.approx(0.5)
    assert flight_metrics(log, modes, failure_s=2.0)["detected_after_s"] is None  # injected, never found
