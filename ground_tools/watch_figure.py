"""The live view's matplotlib figure: velocities and set-points, attitude, tilts, rotor thrust commands, the MPC's
predicted velocity over its horizon and its solve times, drawn from a TelemetryView (`vtol watch`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ground_tools.telemetry_view import TelemetryView, status_line, time_series

PLOTTED_PLANT = ("speed", "vn", "ve", "vd", "roll", "pitch", "yaw", *(f"tilt{i}" for i in range(1, 5)),
                 *(f"thrust{i}" for i in range(1, 5)))  # fmt: skip


def build_figure(figure: Any) -> dict[str, Any]:
    """Axes and (empty) lines of the live view on a matplotlib Figure; returns the artists by name."""
    axes = figure.subplots(3, 2)
    figure.set_size_inches(13, 9)
    artists: dict[str, Any] = {"axes": axes}
    colours = {"speed": "k", "vn": "C0", "ve": "C1", "vd": "C2", "roll": "C0", "pitch": "C1", "yaw": "C2"}
    spec = [
        (axes[0, 0], "velocity (m/s, NED)", [("speed", "|v|"), ("vn", "v_n"), ("ve", "v_e"), ("vd", "v_d")]),
        (axes[0, 1], "attitude (deg)", [("roll", "roll"), ("pitch", "pitch"), ("yaw", "yaw")]),
        (axes[1, 0], "tilt (deg)", [(f"tilt{i}", f"servo {i}") for i in range(1, 5)]),
        (axes[1, 1], "rotor thrust command (fraction)", [(f"thrust{i}", f"rotor {i}") for i in range(1, 5)]),
    ]
    for axis, title, lines in spec:
        for name, label in lines:
            (artists[name],) = axis.plot([], [], label=label, color=colours.get(name), linewidth=1.2)
        axis.set_title(title, fontsize="medium")
        axis.set_xlabel("t (s, simulation)")
        axis.grid(True, alpha=0.3)
    for name, axis in (("vn", axes[0, 0]), ("ve", axes[0, 0]), ("vd", axes[0, 0]),
                       ("roll", axes[0, 1]), ("pitch", axes[0, 1]), ("yaw", axes[0, 1])):  # fmt: skip
        (artists[f"{name}_sp"],) = axis.plot([], [], linestyle="--", color=colours[name], linewidth=1.0,
                                             label="set-points" if name in ("vn", "roll") else None)  # fmt: skip
    for axis in axes[0, 0], axes[0, 1], axes[1, 0], axes[1, 1]:
        axis.legend(loc="upper left", fontsize="x-small", ncol=3)
    horizon = axes[2, 0]
    for i, name in enumerate(("vn", "ve", "vd")):
        (artists[f"mpc_{name}"],) = horizon.plot([], [], marker=".", color=f"C{i}", label=f"{name} predicted")
    for i, name in enumerate(("vn", "ve", "vd")):
        (artists[f"mpc_{name}_sp"],) = horizon.plot([], [], linestyle="--", color=f"C{i}", linewidth=1.0)
    artists["mpc_note"] = horizon.text(0.5, 0.5, "no MPC solution received", transform=horizon.transAxes,
                                       ha="center", va="center", color="0.5")  # fmt: skip
    artists["mpc_title"] = horizon.set_title("MPC predicted velocity (m/s)", fontsize="medium")
    horizon.set_xlabel("horizon stage")
    horizon.grid(True, alpha=0.3)
    horizon.legend(loc="upper left", fontsize="x-small", ncol=3)
    solve = axes[2, 1]
    (artists["solve_ms"],) = solve.plot([], [], color="C3", linewidth=1.0)
    solve.set_title("MPC solve time (ms)", fontsize="medium")
    solve.set_xlabel("t (s, simulation)")
    solve.grid(True, alpha=0.3)
    artists["title"] = figure.suptitle("waiting for telemetry...", fontsize="small", family="monospace")
    figure.tight_layout(rect=(0, 0, 1, 0.96))
    return artists


def draw(artists: dict[str, Any], view: TelemetryView) -> None:
    """Put the view's buffers into the figure's lines and rescale the axes."""
    plant = time_series(view.plant, PLOTTED_PLANT)
    for name, values in plant.items():
        if name != "t":
            artists[name].set_data(plant["t"], values)
    control = time_series(view.control, ("vn_sp", "ve_sp", "vd_sp", "roll_sp", "pitch_sp", "yaw_sp"))
    for name, values in control.items():
        if name != "t":
            artists[name].set_data(control["t"], values)
    solves = time_series(view.solves, ("ms",))
    artists["solve_ms"].set_data(solves["t"], solves["ms"])
    if view.last_mpc is not None:
        predicted = view.last_mpc["predicted_velocity"]
        stages = np.arange(predicted.shape[0])
        for i, name in enumerate(("vn", "ve", "vd")):
            artists[f"mpc_{name}"].set_data(stages, predicted[:, i])
            if view.last_control is not None:  # the set-point the horizon aims at (dashed)
                artists[f"mpc_{name}_sp"].set_data(stages[[0, -1]], [view.last_control[f"{name}_sp"]] * 2)
        artists["mpc_note"].set_visible(False)
        artists["mpc_title"].set_text(
            f"MPC predicted velocity (m/s) at t = {view.last_mpc['t']:.2f} s"
            + ("" if view.last_mpc["ok"] else f" FAILED ({view.last_mpc['status']})")
        )
    latest = max((b[-1]["t"] for b in (view.plant, view.control, view.solves) if b), default=None)
    axes = artists["axes"]
    for axis in axes.flat:
        axis.relim()
        axis.autoscale_view()
        if latest is not None and axis is not axes[2, 0]:
            axis.set_xlim(max(0.0, latest - view.window_s), max(latest, 1.0))
    artists["title"].set_text(status_line(view))


def save_snapshot(view: TelemetryView, path: Path) -> None:
    """Draw the view into a new Agg figure and write it (format from the suffix)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure()
    FigureCanvasAgg(figure)
    draw(build_figure(figure), view)
    figure.savefig(path, dpi=90)
