"""The telemetry a live view keeps: one vehicle's zenoh samples decoded into ring buffers of the last WINDOW_S
seconds of simulation time, and the one-line status read from them. Pure and zenoh-free: `TelemetryView.add(key,
payload)` files a sample; `status_line` and `time_series` read it (`vtol watch`, docs/telemetry.md).
"""

from __future__ import annotations

import math
from collections import Counter, deque
from typing import Any

import numpy as np

from ground_tools.telemetry_record import decoded_samples

WINDOW_S = 30.0  # simulation seconds kept in the ring buffers
PLANT_MIN_DT_S = 0.02  # plant rows kept at most every 20 ms of simulation time (the plant publishes at 400 Hz)


def euler_deg(qw: float, qx: float, qy: float, qz: float) -> tuple[float, float, float]:
    """ZYX roll, pitch, yaw (deg) of the body FRD -> NED quaternion."""
    roll = math.atan2(2 * (qw * qx + qy * qz), 1 - 2 * (qx * qx + qy * qy))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (qw * qy - qz * qx))))
    yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
    return math.degrees(roll), math.degrees(pitch), math.degrees(yaw)


def plant_row(state: dict[str, float]) -> dict[str, float]:
    """What the view keeps of one plant state: time, altitude, velocities, attitude (deg), tilts (deg), thrust."""
    roll, pitch, yaw = euler_deg(state["qw"], state["qx"], state["qy"], state["qz"])
    row = {
        "t": state["t"],
        "alt": -state["down"],
        "vn": state["vn"],
        "ve": state["ve"],
        "vd": state["vd"],
        "speed": math.sqrt(state["vn"] ** 2 + state["ve"] ** 2 + state["vd"] ** 2),
        "roll": roll,
        "pitch": pitch,
        "yaw": yaw,
    }
    for i in range(1, 5):
        row[f"tilt{i}"] = math.degrees(state[f"tilt{i}"])
        row[f"thrust{i}"] = state[f"cmd_thrust{i}"]
    row["tilt_mean"] = sum(row[f"tilt{i}"] for i in range(1, 5)) / 4
    return row


def control_row(control: dict) -> dict[str, Any]:
    """What the view keeps of one autopilot/control sample: time, velocity and attitude set-points, mode."""
    # a non-finite number arrives as null (orjson): nan here, as a gap in the plot
    vsp = np.asarray(control["velocity_sp"], dtype=float)
    esp = np.degrees(np.asarray(control["euler_sp"], dtype=float))
    return {
        "t": float(control["t"]),
        "vn_sp": float(vsp[0]),
        "ve_sp": float(vsp[1]),
        "vd_sp": float(vsp[2]),
        "roll_sp": float(esp[0]),
        "pitch_sp": float(esp[1]),
        "yaw_sp": float(esp[2]),
        "mode": str(control["mode"]),
    }


def push(buffer: deque, row: dict, window_s: float, min_dt_s: float = 0.0) -> bool:
    """Append `row` to a time-ordered ring buffer and drop rows older than `window_s` before it. A time going
    back (a new run) empties the buffer first. Rows closer than `min_dt_s` to the last kept one are skipped.
    Returns whether the row was kept."""
    t = row["t"]
    if buffer:
        last = buffer[-1]["t"]
        if t < last:
            buffer.clear()
        elif t - last < min_dt_s - 1e-9:
            return False
    buffer.append(row)
    while buffer[0]["t"] < t - window_s:
        buffer.popleft()
    return True


def time_series(buffer: deque, names: tuple[str, ...] | list[str]) -> dict[str, np.ndarray]:
    """Columns of a ring buffer as arrays ("t" included)."""
    return {name: np.array([row[name] for row in buffer], dtype=float) for name in ("t", *names)}


class TelemetryView:
    """Ring buffers of one vehicle's telemetry (the last `window_s` simulation seconds) and the latest samples."""

    def __init__(self, window_s: float = WINDOW_S, plant_min_dt_s: float = PLANT_MIN_DT_S) -> None:
        self.window_s = window_s
        self.plant_min_dt_s = plant_min_dt_s
        self.plant: deque[dict] = deque()
        self.control: deque[dict] = deque()
        self.solves: deque[dict] = deque()  # {"t", "ms", "ok"}
        self.last_plant: dict[str, float] | None = None  # the latest row (also the ones thinned out)
        self.last_control: dict | None = None
        self.last_mpc: dict | None = None
        self.events: deque[str] = deque(maxlen=20)
        self.events_total = 0
        self.samples: Counter[str] = Counter()
        self.errors: Counter[str] = Counter()
        self.last_error: str = ""

    def add(self, key: str, payload: bytes) -> None:
        """Decode a payload and file its samples; each one that does not decode or fit is counted in `errors` (and
        as a sample), never raised."""
        values, errors = decoded_samples(key, payload)
        self.samples[key] += len(values) + len(errors)
        for value in values:
            try:
                self.add_decoded(key, value)
            except (ValueError, KeyError, IndexError, TypeError) as exc:
                errors.append(repr(exc))
        if errors:
            self.errors[key] += len(errors)
            self.last_error = f"{key}: {errors[-1]}"

    def add_decoded(self, key: str, value: Any) -> None:
        if key.endswith("/plant/state"):
            row = plant_row(value)
            self.last_plant = row
            push(self.plant, row, self.window_s, self.plant_min_dt_s)
        elif key.endswith("/autopilot/control"):
            row = control_row(value)
            self.last_control = row
            push(self.control, row, self.window_s)
        elif key.endswith("/autopilot/mpc"):
            predicted = np.asarray(value["predicted_velocity"], dtype=float)
            if predicted.ndim != 2 or predicted.shape[1] != 3:
                raise ValueError(f"predicted_velocity has shape {predicted.shape}, expected (N+1, 3)")
            self.last_mpc = {"t": float(value["t"]), "ms": float(value["solve_time_ms"]),
                             "ok": bool(value["ok"]), "status": str(value.get("status", "")),
                             "predicted_velocity": predicted}  # fmt: skip
            push(self.solves, {"t": self.last_mpc["t"], "ms": self.last_mpc["ms"], "ok": self.last_mpc["ok"]},
                 self.window_s)  # fmt: skip
        elif key.endswith("/events"):
            self.events_total += 1
            if isinstance(value, dict):
                self.events.append(f"t={float(value.get('t', math.nan)):.2f} s {value.get('text', value)}")
            else:
                self.events.append(str(value))


def status_line(view: TelemetryView) -> str:
    """One compact line: sim time, altitude, speed, roll/pitch/yaw, mean tilt, mode, MPC solve time."""
    p = view.last_plant
    mode = view.last_control["mode"] if view.last_control else "-"
    mpc = f"{view.last_mpc['ms']:.2f} ms" if view.last_mpc else "-"
    if view.last_mpc and not view.last_mpc["ok"]:
        mpc += " FAILED"
    if p is None:
        return f"t=- (no plant state yet)  mode={mode}  mpc={mpc}"
    return (f"t={p['t']:8.2f} s  alt={p['alt']:7.1f} m  speed={p['speed']:5.1f} m/s  "
            f"roll={p['roll']:6.1f} pitch={p['pitch']:6.1f} yaw={p['yaw']:6.1f} deg  "
            f"tilt={p['tilt_mean']:5.1f} deg  mode={mode}  mpc={mpc}")  # fmt: skip
