"""The scenario metrics of SPEC section 7, computed from a flight log (the autopilot's 100 Hz CSV columns).

Pure functions of arrays, so each metric can be checked by hand on a synthetic flight. SI units unless the
key says otherwise; NED axes: x = north, y = east, z = down.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

REACH_TOLERANCE = 0.5  # m/s: "reached" the target speed when within this of it
GROUND_CLEARANCE = 1.0  # m: closer than this to the ground counts as ground contact for `survived`
ATTITUDE_LIMIT_DEG = 60.0  # survived = |roll| and |pitch| stayed below this
TURN_SETTLE_S = 5.0  # the steady turn (mean bank) starts this long after the circle begins
FINAL_WINDOW_S = 1.0  # final_speed: mean speed over the last second


@dataclass(frozen=True)
class Circle:
    """The intended circle of a circle scenario: it starts at `start_s`, flown clockwise seen from above
    (north, then east) at the start heading north, with radius `radius`."""

    start_s: float
    radius: float


def rms(values: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(values)))) if values.size else math.nan


def time_to_reach(t: np.ndarray, speed: np.ndarray, target: float) -> float | None:
    """First time the speed is within REACH_TOLERANCE of the target, or None."""
    hits = np.flatnonzero(np.abs(speed - target) <= REACH_TOLERANCE)
    return float(t[hits[0]]) if hits.size else None


def tilt_tv_ratio(mean_tilt: np.ndarray) -> float:
    """Total variation over range of the mean tilt: 1 for a monotonic profile, larger the more it goes back and
    forth (the PID's steps, the MPC's swing back while braking); NaN if it never moved."""
    spread = float(np.ptp(mean_tilt)) if mean_tilt.size else 0.0
    return float(np.sum(np.abs(np.diff(mean_tilt)))) / spread if spread > 0 else math.nan


def mode_switches(modes: list[str]) -> int:
    return sum(1 for previous, current in zip(modes, modes[1:]) if current != previous)


def circle_errors(t: np.ndarray, north: np.ndarray, east: np.ndarray, circle: Circle) -> tuple[float, float]:
    """RMS and max of |distance to the intended centre| - R after the circle starts. The centre lies R to the
    right (east) of where the vehicle is when the circle begins, heading north."""
    flying = t >= circle.start_s
    if not np.any(flying):
        return math.nan, math.nan
    first = int(np.flatnonzero(flying)[0])
    centre_north, centre_east = north[first], east[first] + circle.radius
    radial = np.hypot(north[flying] - centre_north, east[flying] - centre_east) - circle.radius
    return rms(radial), float(np.abs(radial).max())


def mean_bank_deg(t: np.ndarray, roll: np.ndarray, circle: Circle) -> float:
    """Mean roll (deg) in the steady turn: from TURN_SETTLE_S after the circle begins to the end."""
    steady = t >= circle.start_s + TURN_SETTLE_S
    return float(np.degrees(np.mean(roll[steady]))) if np.any(steady) else math.nan


def flight_metrics(
    log: dict[str, np.ndarray],
    modes: list[str],
    solver: dict | None = None,
    circle: Circle | None = None,
    failure_s: float | None = None,
) -> dict[str, float | int | bool | None]:
    """SPEC 7's keys for one run, and a few more the scenarios' acceptance needs (`bank_mean_deg`,
    `alt_loss_max_m`, `final_speed`, `failure_t_s`, `vx_rmse_after_failure`). `solver`: the autopilot's MPC
    statistics (absent for the PID); `failure_s`: when a failure was injected."""
    t = log["t"]
    altitude = -log["down"]
    roll_deg, pitch_deg = np.degrees(np.abs(log["roll"])), np.degrees(np.abs(log["pitch"]))
    horizontal_sp = np.hypot(log["vn_sp"], log["ve_sp"])
    mean_tilt = np.mean([log[f"tilt_est{i}"] for i in range(1, 5)], axis=0)
    speed = np.linalg.norm([log["vn"], log["ve"], log["vd"]], axis=0)
    metrics: dict[str, float | int | bool | None] = {
        "vx_rmse": rms(log["vn"] - log["vn_sp"]),
        "vy_rmse": rms(log["ve"] - log["ve_sp"]),
        "vz_rmse": rms(log["vd"] - log["vd_sp"]),
        "vz_max_abs": float(np.abs(log["vd"]).max()),
        "roll_max_abs_deg": float(roll_deg.max()),
        "pitch_max_abs_deg": float(pitch_deg.max()),
        "alt_change_max_m": float(np.abs(altitude - altitude[0]).max()),
        "t_reach_s": time_to_reach(t, np.hypot(log["vn"], log["ve"]), float(horizontal_sp.max())),
        "tilt_tv_ratio": tilt_tv_ratio(np.degrees(mean_tilt)),
        "mode_switches": mode_switches(modes),
        "radial_rmse_m": None,
        "radial_max_m": None,
        "solve_ms_median": None,
        "solve_ms_p99": None,
        "solve_ms_max": None,
        "solves_failed": None,
        "alt_loss_max_m": float(max(0.0, (altitude[0] - altitude).max())),
        "final_speed": float(np.mean(speed[t >= t[-1] - FINAL_WINDOW_S])),
        "bank_mean_deg": None,
        "failure_t_s": failure_s,
        "vx_rmse_after_failure": None,
        "survived": bool(altitude.min() > GROUND_CLEARANCE and roll_deg.max() < ATTITUDE_LIMIT_DEG
                         and pitch_deg.max() < ATTITUDE_LIMIT_DEG),
    }  # fmt: skip
    if circle is not None:
        metrics["radial_rmse_m"], metrics["radial_max_m"] = circle_errors(t, log["north"], log["east"], circle)
        metrics["bank_mean_deg"] = mean_bank_deg(t, log["roll"], circle)
    if failure_s is not None:
        after = t >= failure_s
        metrics["vx_rmse_after_failure"] = rms(log["vn"][after] - log["vn_sp"][after])
    if solver:
        for key in ("solve_ms_median", "solve_ms_p99", "solve_ms_max", "solves_failed"):
            metrics[key] = solver.get(key)
    return metrics
