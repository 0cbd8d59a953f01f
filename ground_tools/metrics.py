"""The scenario metrics of docs/scenarios.md, computed from a flight log's columns (transport/flight_log.py).

Pure functions of arrays, so each metric can be checked by hand on a synthetic flight. SI units unless the
key says otherwise; NED axes: x = north, y = east, z = down.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping

import numpy as np

from scenarios.experiments import Circle
from transport.flight_log import DOWN, EAST, NORTH, PITCH, ROLL, TILT_EST, VD, VD_SP, VE, VE_SP, VN, VN_SP, YAW, T

REACH_TOLERANCE = 0.5  # m/s: "reached" the target speed when within this of it
GROUND_CLEARANCE = 1.0  # m: closer than this to the ground counts as ground contact for `survived`
ATTITUDE_LIMIT_DEG = 60.0  # survived = |roll| and |pitch| stayed below this
TURN_SETTLE_S = 5.0  # the steady turn (mean bank) starts this long after the circle begins
FINAL_WINDOW_S = 1.0  # final_speed: mean speed over the last second
COURSE_MIN_SPEED = 1.0  # m/s: heading_error_max_deg counts where the horizontal set-point is at least this fast
# The STATUSTEXTs the autopilot's failure detector sends on finding a failure (docs/failures.md).
FAILURE_FOUND = re.compile(r"failure detected|jam detected")


METRIC_KINDS: dict[str, type] = {
    **{key: float for key in (
        "vx_rmse", "vy_rmse", "vz_rmse", "vz_max_abs", "roll_max_abs_deg", "pitch_max_abs_deg",
        "heading_error_max_deg", "alt_change_max_m", "alt_loss_max_m", "t_reach_s", "tilt_tv_ratio", "radial_rmse_m",
        "radial_max_m", "bank_mean_deg", "final_speed", "failure_t_s", "detected_after_s", "vx_rmse_after_failure",
        "solve_ms_median", "solve_ms_p99", "solve_ms_max")},
    "mode_switches": int,
    "solves_failed": int,
    "survived": bool,
}  # fmt: skip
"""Every metric flight_metrics gives, by name, and the kind of its value (None where it does not apply)."""


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


def mean_tilt(log: Mapping[str, np.ndarray]) -> np.ndarray:
    """The four rotors' mean estimated tilt (rad) at each row."""
    return np.mean([log[name] for name in TILT_EST], axis=0)


def heading_error_max_deg(yaw: np.ndarray, vn_sp: np.ndarray, ve_sp: np.ndarray) -> float | None:
    """Largest |yaw - the set-point's course| (deg, wrapped to 180) where the horizontal set-point is at least
    COURSE_MIN_SPEED; None if it never is. The scenarios fly with the nose on the course, so a large value is the
    aircraft turned across its path (a controller braking on the fuselage's side force, docs/design/alternatives.md, the long horizon)."""
    moving = np.hypot(vn_sp, ve_sp) >= COURSE_MIN_SPEED
    if not np.any(moving):
        return None
    difference = yaw[moving] - np.arctan2(ve_sp[moving], vn_sp[moving])
    error = np.arctan2(np.sin(difference), np.cos(difference))  # wrapped, as autopilot.control.attitude.wrap
    return float(np.degrees(np.abs(error)).max())


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


def detection_time(statustexts: Iterable[tuple[float, str]], failure_s: float | None) -> float | None:
    """When (s) the autopilot first said it found a failure (FAILURE_FOUND) at or after `failure_s`, from the
    flight's (time s, text) STATUSTEXTs; None without a failure or a finding."""
    if failure_s is None:
        return None
    return next((t for t, text in statustexts if t >= failure_s and FAILURE_FOUND.search(text)), None)


def flight_metrics(
    log: Mapping[str, np.ndarray],
    modes: list[str],
    solver: dict | None = None,
    circle: Circle | None = None,
    failure_s: float | None = None,
    detected_s: float | None = None,
) -> dict[str, float | int | bool | None]:
    """The keys of docs/scenarios.md for one run, and a few more the scenarios' acceptance needs (`bank_mean_deg`,
    `alt_loss_max_m`, `final_speed`, `failure_t_s`, `detected_after_s`, `vx_rmse_after_failure`). `solver`: the
    autopilot's MPC statistics (absent for the PID); `failure_s`: when a failure was injected, `detected_s` when the
    autopilot said it found it (detection_time). `log`: the flight log's numeric columns by name, `modes` its mode
    column."""
    t = log[T]
    altitude = -log[DOWN]
    roll_deg, pitch_deg = np.degrees(np.abs(log[ROLL])), np.degrees(np.abs(log[PITCH]))
    horizontal_sp = np.hypot(log[VN_SP], log[VE_SP])
    speed = np.linalg.norm([log[VN], log[VE], log[VD]], axis=0)
    metrics: dict[str, float | int | bool | None] = {
        "vx_rmse": rms(log[VN] - log[VN_SP]),
        "vy_rmse": rms(log[VE] - log[VE_SP]),
        "vz_rmse": rms(log[VD] - log[VD_SP]),
        "vz_max_abs": float(np.abs(log[VD]).max()),
        "roll_max_abs_deg": float(roll_deg.max()),
        "pitch_max_abs_deg": float(pitch_deg.max()),
        "heading_error_max_deg": heading_error_max_deg(log[YAW], log[VN_SP], log[VE_SP]),
        "alt_change_max_m": float(np.abs(altitude - altitude[0]).max()),
        "t_reach_s": time_to_reach(t, np.hypot(log[VN], log[VE]), float(horizontal_sp.max())),
        "tilt_tv_ratio": tilt_tv_ratio(np.degrees(mean_tilt(log))),
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
        "detected_after_s": None if failure_s is None or detected_s is None else detected_s - failure_s,
        "vx_rmse_after_failure": None,
        "survived": bool(altitude.min() > GROUND_CLEARANCE and roll_deg.max() < ATTITUDE_LIMIT_DEG
                         and pitch_deg.max() < ATTITUDE_LIMIT_DEG),
    }  # fmt: skip
    if circle is not None:
        metrics["radial_rmse_m"], metrics["radial_max_m"] = circle_errors(t, log[NORTH], log[EAST], circle)
        metrics["bank_mean_deg"] = mean_bank_deg(t, log[ROLL], circle)
    if failure_s is not None:
        after = t >= failure_s
        metrics["vx_rmse_after_failure"] = rms(log[VN][after] - log[VN_SP][after])
    if solver:
        for key in ("solve_ms_median", "solve_ms_p99", "solve_ms_max", "solves_failed"):
            metrics[key] = solver.get(key)
    return metrics
