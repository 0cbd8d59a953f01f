"""Run the real plant and autopilot processes together in lockstep and read the autopilot's flight log."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ground_tools.lockstep_flight import fly_lockstep


@dataclass
class Flight:
    """One lockstep flight: the autopilot's 100 Hz log as columns, and both processes' --summary."""

    log: dict[str, np.ndarray]
    modes: list[str]
    autopilot: dict
    plant: dict

    def at(self, t: float) -> dict[str, float]:
        """The log row nearest to time t (s since the profile start)."""
        i = int(np.argmin(np.abs(self.log["t"] - t)))
        return {name: float(column[i]) for name, column in self.log.items()}

    def between(self, start: float, end: float = float("inf")) -> dict[str, np.ndarray]:
        mask = (self.log["t"] >= start) & (self.log["t"] <= end)
        return {name: column[mask] for name, column in self.log.items()}


def fly(
    tmp_path: Path, profile: str, duration: float, *autopilot_args: str, spawn_alt: float = 100.0,
    controller: str = "pid",
) -> Flight:
    """Plant spawned hovering at spawn_alt, the autopilot flying `profile` for `duration` simulated seconds."""
    log_path = tmp_path / f"{profile}-{controller}.csv"
    flight = fly_lockstep(profile, duration, controller=controller, spawn_alt=spawn_alt, log_path=log_path,
                          autopilot_args=autopilot_args)  # fmt: skip
    with open(log_path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    columns = {name: np.array([float(row[name]) for row in rows]) for name in rows[0] if name != "mode"}
    return Flight(log=columns, modes=[row["mode"] for row in rows], autopilot=flight.autopilot, plant=flight.plant)
