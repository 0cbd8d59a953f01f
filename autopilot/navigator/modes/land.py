"""Land (PX4's AUTO.LAND): brake, descend, touch down; PX4's Descend (position lost): the same with no horizontal
position control, only a zero horizontal velocity."""

from __future__ import annotations

import numpy as np

from autopilot.navigator.mode import FlightMode, ModeContext
from autopilot.topics.flight_mode import PX4_AUTO_LAND, PX4_MAIN_AUTO, ModeId
from autopilot.topics.vehicle_state import VehicleState

LAND = "Land"


class LandMode(FlightMode):
    """AUTO.LAND: brake, descend, touch down; PX4's Descend (position lost): the same with no horizontal position
    control, only a zero horizontal velocity."""

    id = ModeId(LAND, PX4_MAIN_AUTO, PX4_AUTO_LAND)
    needs_position = False  # Descend flies without one
    resets_land_detector = True

    @property
    def landing(self) -> bool:
        return True

    def __init__(self, context: ModeContext) -> None:
        self.tasks = context.tasks
        self.descend = False

    def activate(self, state: VehicleState) -> None:
        self.descend = False
        self.tasks.start_land(state)

    def setpoint(self, state: VehicleState) -> np.ndarray:
        setpoint = self.tasks.land(state)
        if self.descend:
            setpoint[0:2] = 0.0
        return setpoint
