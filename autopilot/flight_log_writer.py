"""The autopilot's 100 Hz flight log (`--log FILE.csv`): one row per velocity-controller tick in the declared
schema of transport/flight_log.py (truth state, set-points, tilt commands and estimates, actuators, residual,
the controller's phase)."""

from __future__ import annotations

import csv
from typing import IO

import numpy as np

from aircraft.actuators import ROTORS, SURFACES, TILTS
from autopilot.flight_controller import FlightController
from autopilot.vehicle_state import VehicleState
from transport.flight_log import COLUMNS

PERIOD_USEC = 10_000  # the velocity controller's 100 Hz


class FlightLogWriter:
    def __init__(self, handle: IO[str]) -> None:
        self._writer = csv.writer(handle)
        self._writer.writerow(COLUMNS)
        self._next_usec = 0

    def restart(self) -> None:
        self._next_usec = 0

    def maybe_write(self, t: float, time_usec: int, s: VehicleState, c: FlightController) -> None:
        """A row when its 10 ms are due (t: seconds since the flight's start)."""
        if time_usec < self._next_usec:
            return
        self._next_usec = time_usec + PERIOD_USEC
        cmd, vc = c.command, c.velocity_command
        self._writer.writerow(
            [f"{t:.4f}"]
            + [f"{v:.5g}" for v in (*s.position_ned, *s.velocity_ned, *s.euler, *s.body_rates, s.airspeed)]
            + [f"{v:.5g}" for v in (*c.velocity_setpoint, *vc.euler_sp, *cmd[TILTS], *c.servos.tilt)]
            + [f"{v:.5g}" for v in (*cmd[ROTORS], *cmd[SURFACES])]
            + [f"{float(np.linalg.norm(c.residual[0:3])):.4g}", f"{float(np.linalg.norm(c.residual[3:6])):.4g}"]
            + [vc.mode]
        )
