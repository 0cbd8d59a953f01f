"""The autopilot's 100 Hz flight log (`--log FILE.csv`): a row per velocity-controller tick in the declared
schema of transport/flight_log.py (truth state, set-points, tilt commands and estimates, actuators, residual,
the controller's phase)."""

from __future__ import annotations

import math
from typing import IO

from aircraft.actuators import TILTS, allocated_of
from autopilot.control.flight_controller import FlightController
from autopilot.topics.vehicle_state import VehicleState
from transport.flight_log import FlightLogWriter

PERIOD_USEC = 10_000  # the velocity controller's 100 Hz


class FlightLogger:
    def __init__(self, handle: IO[str]) -> None:
        self._writer = FlightLogWriter(handle)
        self._next_usec = 0

    def restart(self) -> None:
        self._next_usec = 0

    def maybe_write(self, t: float, time_usec: int, s: VehicleState, c: FlightController) -> None:
        """A row when its 10 ms are due (t: seconds since the flight's start)."""
        if time_usec < self._next_usec:
            return
        self._next_usec = time_usec + PERIOD_USEC
        residual = c.residual
        self._writer.write(
            (t, *s.position_ned, *s.velocity_ned, *s.euler, *s.body_rates, s.airspeed, *c.velocity_setpoint,
             *c.velocity_command.euler_sp, *c.command[TILTS], *c.servos.tilt, *allocated_of(c.command),
             math.hypot(*residual[0:3].tolist()), math.hypot(*residual[3:6].tolist())),
            c.velocity_command.mode,
        )  # fmt: skip
