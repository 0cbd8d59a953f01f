"""Fly a profile with the real plant and autopilot processes in lockstep (through the public API) and read the
autopilot's flight log."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tiltrotor_sitl import Controller, ProcessOptions, Vehicle
from transport.flight_log import T, read_flight_log


@dataclass
class Flight:
    """One lockstep flight: the autopilot's 100 Hz log as columns, and both processes' --summary."""

    log: dict[str, np.ndarray]
    modes: list[str]
    autopilot: dict
    plant: dict

    def at(self, t: float) -> dict[str, float]:
        """The log row nearest to time t (s since the profile start)."""
        i = int(np.argmin(np.abs(self.log[T] - t)))
        return {name: float(column[i]) for name, column in self.log.items()}

    def between(self, start: float, end: float = float("inf")) -> dict[str, np.ndarray]:
        mask = (self.log[T] >= start) & (self.log[T] <= end)
        return {name: column[mask] for name, column in self.log.items()}


def fly(
    tmp_path: Path,
    profile: str,
    duration: float,
    *autopilot_args: str,
    spawn_alt: float = 100.0,
    controller: Controller = "pid",
) -> Flight:
    """Plant spawned hovering at spawn_alt, the autopilot flying `profile` for `duration` simulated seconds, in
    lockstep as fast as the processes go (tiltrotor_sitl.Vehicle with speed=None)."""
    log_path = tmp_path / f"{profile}-{controller}.csv"
    with Vehicle(
        controller=controller,
        spawn_alt=spawn_alt,
        speed=None,
        truth=False,
        processes=ProcessOptions(
            summary=True,
            duration_s=duration,
            wait_ready=False,
            autopilot_args=("--profile", profile, "--log", str(log_path), "--quiet", *autopilot_args),
        ),
    ) as vehicle:
        vehicle.wait_finished(timeout_s=900.0)
        autopilot, plant = vehicle.summary("vtol-autopilot"), vehicle.summary("vtol-sim")
    log = read_flight_log(log_path)
    return Flight(log=log.columns, modes=log.modes, autopilot=autopilot, plant=plant)
