"""Figures like the paper's from an autopilot flight log (the 100 Hz CSV of `vtol-autopilot --log`,
transport/flight_log.py)."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import numpy as np

from aircraft.actuators import ACTUATOR_NAMES, SURFACES
from transport import flight_log


@functools.cache
def pyplot() -> Any:
    """matplotlib.pyplot on the Agg backend (files only, no display), imported at the first figure: half a second
    that the commands drawing none (`vtol up`, `record`, `watch`) and the processes they start need not pay."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_flight(log: flight_log.FlightLog, out_dir: Path, title: str) -> list[Path]:
    """Velocity tracking (x, z), tilt and pitch, roll and yaw, actuator commands, ground track. Returns the files."""
    plt = pyplot()
    out_dir.mkdir(parents=True, exist_ok=True)
    t = log[flight_log.T]
    deg = np.degrees
    tilts = [(deg(log[name]), f"servo {i}") for i, name in enumerate(flight_log.TILT_EST, start=1)]
    thrusts = [(log[name], f"motor {i}") for i, name in enumerate(flight_log.THRUST, start=1)]
    surfaces = [(log[name], legend) for name, legend in zip(flight_log.SURFACE, ACTUATOR_NAMES[SURFACES])]
    panels = {
        "velocity.png": [
            ("v_x (m/s)", [(log[flight_log.VN], "v_x"), (log[flight_log.VN_SP], "set-point")]),
            ("v_z (m/s, down)", [(log[flight_log.VD], "v_z"), (log[flight_log.VD_SP], "set-point")]),
        ],
        "tilt_pitch.png": [
            ("tilt (deg)", tilts),
            ("pitch (deg)", [(deg(log[flight_log.PITCH]), "pitch"), (deg(log[flight_log.PITCH_SP]), "set-point")]),
        ],
        "roll_yaw.png": [
            ("roll (deg)", [(deg(log[flight_log.ROLL]), "roll"), (deg(log[flight_log.ROLL_SP]), "set-point")]),
            ("yaw (deg)", [(deg(np.unwrap(log[flight_log.YAW])), "yaw"),
                           (deg(np.unwrap(log[flight_log.YAW_SP])), "set-point")]),
        ],
        "actuators.png": [("rotor thrust (fraction)", thrusts), ("surfaces (-1..1)", surfaces)],
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
    axis.plot(log[flight_log.EAST], log[flight_log.NORTH])
    written.append(save_ground_track(figure, axis, f"{title}: ground track", out_dir / "ground_track.png"))
    return written


def save_ground_track(figure, axis, title: str, path: Path) -> Path:
    """Label, square and save a north-over-east ground-track figure."""
    plt = pyplot()
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
