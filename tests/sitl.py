"""Run the real plant and autopilot processes together in lockstep and read the autopilot's flight log."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tests.conftest import free_udp_port


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


def fly(tmp_path: Path, profile: str, duration: float, *autopilot_args: str, spawn_alt: float = 100.0) -> Flight:
    """Plant spawned hovering at spawn_alt, the autopilot flying `profile` for `duration` simulated seconds."""
    port = free_udp_port()
    log_path = tmp_path / f"{profile}.csv"
    plant = subprocess.Popen(
        [sys.executable, "-m", "sim_bridge", "--port", str(port), "--spawn-alt", str(spawn_alt), "--no-zenoh",
         "--duration", str(duration), "--lockstep-timeout", "0.5", "--summary"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        autopilot = subprocess.run(
            [sys.executable, "-m", "autopilot", "--sim-port", str(port), "--spawn-alt", str(spawn_alt),
             "--profile", profile, "--duration", str(duration), "--log", str(log_path), "--summary",
             "--no-zenoh", *autopilot_args],
            capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        plant_out, plant_err = plant.communicate(timeout=120)
    finally:
        if plant.poll() is None:
            plant.kill()
            plant.wait()
    assert autopilot.returncode == 0, autopilot.stderr
    assert plant.returncode == 0, plant_err
    with open(log_path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    columns = {name: np.array([float(row[name]) for row in rows]) for name in rows[0] if name != "mode"}
    return Flight(
        log=columns,
        modes=[row["mode"] for row in rows],
        autopilot=json.loads(autopilot.stdout.strip().splitlines()[-1]),
        plant=json.loads(plant_out.strip().splitlines()[-1]),
    )
