"""Takeoff (PX4's AUTO.TAKEOFF): climb over the takeoff point to the target altitude (then the commander holds
there). Chosen as a mode, it is a takeoff to MIS_TAKEOFF_ALT (the commander's takeoff)."""

from __future__ import annotations

import numpy as np

from autopilot.navigator.mode import FlightMode, ModeContext
from autopilot.topics.flight_mode import PX4_AUTO_TAKEOFF, PX4_MAIN_AUTO, ModeId
from autopilot.topics.vehicle_state import VehicleState

TAKEOFF = "Takeoff"


class TakeoffMode(FlightMode):
    """AUTO.TAKEOFF: climb over the takeoff point to the target altitude (then the commander holds there)."""

    id = ModeId(TAKEOFF, PX4_MAIN_AUTO, PX4_AUTO_TAKEOFF)

    def __init__(self, context: ModeContext) -> None:
        self.tasks = context.tasks

    def start(self, state: VehicleState, target_down: float) -> None:
        self.tasks.start_takeoff(state, target_down)

    def done(self, state: VehicleState) -> bool:
        return self.tasks.takeoff_done(state)

    @property
    def end(self) -> tuple[np.ndarray, float]:
        """Where the takeoff ends: the point and altitude to hold."""
        return self.tasks.takeoff_xy, self.tasks.takeoff_down

    def lifts_off(self, state: VehicleState) -> bool:
        return True

    def setpoint(self, state: VehicleState) -> np.ndarray:
        return self.tasks.takeoff(state)
