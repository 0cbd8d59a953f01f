"""Figures like the paper's for one scenario, with every controller's run overlaid (MPC solid, PID dashed).

velocity.png      v_x, v_y (turning scenarios) and v_z with their set-points
tilt_pitch.png    mean rotor tilt (and servo 1 where it fails) and pitch with its set-point
roll_yaw.png      roll and yaw with their set-points
actuators.png     tilt servo and rotor commands, one column per controller
ground_track.png  north over east, with the intended circle
A failure's injection time is marked by a vertical line.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from aircraft.failures import FailureUnit
from ground_tools.figures import pyplot, save_ground_track
from ground_tools.metrics import mean_tilt
from scenarios.experiments import Scenario
from transport import flight_log

STYLE = {"mpc": ("tab:blue", "-"), "pid": ("tab:orange", "--")}
SETPOINT = {"color": "black", "linestyle": ":", "linewidth": 1.0}  # the intended circle
FIGURE_FILES = ("velocity.png", "tilt_pitch.png", "roll_yaw.png", "actuators.png", "ground_track.png")


def _style(controller: str) -> tuple[str, str]:
    return STYLE.get(controller, ("tab:green", "-."))


def _mark_failures(axes, failures: dict[str, float | None]) -> None:
    for controller, t in failures.items():
        if t is not None:
            for axis in axes:
                axis.axvline(t, color=_style(controller)[0], alpha=0.4, linewidth=0.8)


def _time_figure(runs, failures, panels, title: str, path: Path) -> Path:
    """panels: (ylabel, column or function of a run, set-point column or None)."""
    plt = pyplot()
    figure, axes = plt.subplots(len(panels), 1, figsize=(8, 2.4 * len(panels) + 0.6), sharex=True)
    axes = np.atleast_1d(axes)
    for axis, (label, value, setpoint) in zip(axes, panels):
        for controller, run in runs.items():
            colour, line = _style(controller)
            y = value(run) if callable(value) else run[value]
            axis.plot(run[flight_log.T], y, color=colour, linestyle=line, label=controller.upper())
            if setpoint is not None:
                sp = setpoint(run) if callable(setpoint) else run[setpoint]
                axis.plot(
                    run[flight_log.T],
                    sp,
                    color=colour,
                    linestyle=":",
                    linewidth=1.0,
                    label=f"set-point ({controller.upper()})",
                )
        axis.set_ylabel(label)
        axis.grid(True, alpha=0.3)
        axis.legend(loc="best", fontsize="small")
    _mark_failures(axes, failures)
    axes[-1].set_xlabel("t (s) from the profile start")
    figure.suptitle(title)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


def _deg(column: str):
    return lambda run: np.degrees(run[column])


def _deg_unwrapped(column: str):
    return lambda run: np.degrees(np.unwrap(run[column]))


def _mean_tilt_deg(run: flight_log.FlightLog) -> np.ndarray:
    return np.degrees(mean_tilt(run))


def plot_scenario(
    scenario: Scenario, runs: dict[str, flight_log.FlightLog], failures: dict[str, float | None], out_dir: Path
) -> list[Path]:
    """Write the scenario's figures (every run in `runs` overlaid) to out_dir; returns the files."""
    plt = pyplot()
    out_dir.mkdir(parents=True, exist_ok=True)
    title = f"{scenario.name}: {scenario.summary}"
    turning = scenario.circle is not None
    written = [
        _time_figure(runs, failures, [("v_x (m/s)", flight_log.VN, flight_log.VN_SP)]
                     + ([("v_y (m/s)", flight_log.VE, flight_log.VE_SP)] if turning else [])
                     + [("v_z (m/s, down)", flight_log.VD, flight_log.VD_SP)], title, out_dir / "velocity.png"),
        _time_figure(runs, failures, [("mean tilt (deg)", _mean_tilt_deg, None)]
                     + ([("servo 1 tilt (deg)", _deg(flight_log.TILT_EST[0]), None)] if scenario.failure is not None
                        and scenario.failure.injection.unit == FailureUnit.SERVO else [])
                     + [("pitch (deg)", _deg(flight_log.PITCH), _deg(flight_log.PITCH_SP))], title,
                     out_dir / "tilt_pitch.png"),
        _time_figure(runs, failures, [("roll (deg)", _deg(flight_log.ROLL), _deg(flight_log.ROLL_SP)),
                                      ("yaw (deg)", _deg_unwrapped(flight_log.YAW), _deg_unwrapped(flight_log.YAW_SP))],
                     title, out_dir / "roll_yaw.png"),
    ]  # fmt: skip

    figure, axes = plt.subplots(2, len(runs), figsize=(5 * len(runs) + 1, 6), sharex=True, squeeze=False)
    for column, (controller, run) in enumerate(runs.items()):
        for i, (tilt, thrust) in enumerate(zip(flight_log.TILT_CMD, flight_log.THRUST), start=1):
            axes[0, column].plot(run[flight_log.T], np.degrees(run[tilt]), label=f"servo {i}")
            axes[1, column].plot(run[flight_log.T], run[thrust], label=f"rotor {i}")
        axes[0, column].set_title(controller.upper())
        axes[0, column].set_ylabel("tilt command (deg)")
        axes[1, column].set_ylabel("thrust command (fraction)")
        axes[1, column].set_xlabel("t (s)")
        for axis in axes[:, column]:
            axis.grid(True, alpha=0.3)
            axis.legend(loc="best", fontsize="small")
        _mark_failures(axes[:, column], {controller: failures.get(controller)})
    figure.suptitle(title)
    figure.tight_layout()
    figure.savefig(out_dir / "actuators.png", dpi=110)
    plt.close(figure)
    written.append(out_dir / "actuators.png")

    figure, axis = plt.subplots(figsize=(6.5, 6))
    for controller, run in runs.items():
        colour, line = _style(controller)
        axis.plot(run[flight_log.EAST], run[flight_log.NORTH], color=colour, linestyle=line, label=controller.upper())
        t_fail = failures.get(controller)
        if t_fail is not None:
            k = int(np.searchsorted(run[flight_log.T], t_fail))
            if k < run[flight_log.T].size:
                axis.plot(run[flight_log.EAST][k], run[flight_log.NORTH][k], "x", color=colour, markersize=10,
                          label=f"failure ({controller.upper()})")  # fmt: skip
    if turning:
        run = next(iter(runs.values()))
        k = int(np.searchsorted(run[flight_log.T], scenario.circle.start_s))
        k = min(k, run[flight_log.T].size - 1)
        centre_n, centre_e = run[flight_log.NORTH][k], run[flight_log.EAST][k] + scenario.circle.radius
        angle = np.linspace(0.0, 2 * math.pi, 361)
        axis.plot(centre_e + scenario.circle.radius * np.cos(angle), centre_n + scenario.circle.radius * np.sin(angle),
                  label="intended circle", **SETPOINT)  # fmt: skip
    written.append(save_ground_track(figure, axis, f"{scenario.name}: ground track", out_dir / "ground_track.png"))
    return written
