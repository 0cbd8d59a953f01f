"""Figures like the paper's from an autopilot flight log (the 100 Hz CSV of `vtol-autopilot --log`)."""

from __future__ import annotations

import csv
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only: no display needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read_log(path: Path) -> dict[str, np.ndarray]:
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    if not rows:
        raise ValueError(f"{path}: empty flight log")
    return {name: np.array([float(row[name]) for row in rows]) for name in rows[0] if name != "mode"}


def plot_flight(log: dict[str, np.ndarray], out_dir: Path, title: str) -> list[Path]:
    """Velocity tracking (x, z), tilt and pitch, roll and yaw, actuator commands, ground track. Returns the files."""
    out_dir.mkdir(parents=True, exist_ok=True)
    t = log["t"]
    deg = np.degrees
    panels = {
        "velocity.png": [
            ("v_x (m/s)", [(log["vn"], "v_x"), (log["vn_sp"], "set-point")]),
            ("v_z (m/s, down)", [(log["vd"], "v_z"), (log["vd_sp"], "set-point")]),
        ],
        "tilt_pitch.png": [
            ("tilt (deg)", [(deg(log[f"tilt_est{i}"]), f"servo {i}") for i in range(1, 5)]),
            ("pitch (deg)", [(deg(log["pitch"]), "pitch"), (deg(log["pitch_sp"]), "set-point")]),
        ],
        "roll_yaw.png": [
            ("roll (deg)", [(deg(log["roll"]), "roll"), (deg(log["roll_sp"]), "set-point")]),
            ("yaw (deg)", [(deg(np.unwrap(log["yaw"])), "yaw"), (deg(np.unwrap(log["yaw_sp"])), "set-point")]),
        ],
        "actuators.png": [
            ("rotor thrust (fraction)", [(log[f"u{i}"], f"motor {i}") for i in range(1, 5)]),
            ("surfaces (-1..1)", [(log[f"u{i}"], name) for i, name in
                                  zip(range(5, 9), ("aileron L", "aileron R", "elevator", "rudder"))]),
        ],
    }  # fmt: skip
    written = []
    for name, axes_spec in panels.items():
        figure, axes = plt.subplots(len(axes_spec), 1, figsize=(8, 6), sharex=True)
        for axis, (label, series) in zip(axes, axes_spec):
            for values, legend in series:
                axis.plot(t, values, label=legend, linestyle="--" if legend == "set-point" else "-")
            axis.set_ylabel(label)
            axis.grid(True, alpha=0.3)
            axis.legend(loc="best", fontsize="small")
        axes[-1].set_xlabel("t (s)")
        figure.suptitle(title)
        figure.tight_layout()
        figure.savefig(out_dir / name, dpi=110)
        plt.close(figure)
        written.append(out_dir / name)
    figure, axis = plt.subplots(figsize=(6, 6))
    axis.plot(log["east"], log["north"])
    written.append(save_ground_track(figure, axis, f"{title}: ground track", out_dir / "ground_track.png"))
    return written


def save_ground_track(figure, axis, title: str, path: Path) -> Path:
    """Label, square and save a north-over-east ground-track figure."""
    axis.set_xlabel("east (m)")
    axis.set_ylabel("north (m)")
    axis.set_aspect("equal", adjustable="datalim")
    axis.grid(True, alpha=0.3)
    if axis.get_legend_handles_labels()[0]:
        axis.legend(loc="best", fontsize="small")
    axis.set_title(title)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path
