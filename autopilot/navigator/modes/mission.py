"""Mission (PX4's AUTO.MISSION): the stored mission, item by item (navigator/mission_flight.py); chosen only with a
mission stored that passes the feasibility check."""

from __future__ import annotations

import numpy as np

from autopilot.navigator.mode import FlightMode, ModeContext, ModeEntry
from autopilot.topics.flight_mode import PX4_AUTO_MISSION, PX4_MAIN_AUTO, ModeId
from autopilot.topics.requests import Reply
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawSetpoint
from transport.mavlink import mavlink

MISSION = "Mission"


class MissionMode(FlightMode):
    """AUTO.MISSION: the stored mission, item by item (mission_flight.py)."""

    id = ModeId(MISSION, PX4_MAIN_AUTO, PX4_AUTO_MISSION)

    def __init__(self, context: ModeContext) -> None:
        self.mission = context.mission
        self.feasibility = context.feasibility

    def entry_refusal(self, entry: ModeEntry) -> Reply | None:
        if not self.stored:
            return mavlink.MAV_RESULT_DENIED, "Mission denied: no mission stored"
        if self.feasibility.check() is not None:
            return mavlink.MAV_RESULT_TEMPORARILY_REJECTED, "Switching to Mission is currently not available"
        return None

    @property
    def flies_mission(self) -> bool:
        return True

    @property
    def stored(self) -> bool:
        """A mission is stored to fly."""
        return bool(self.mission.items)

    def activate(self, state: VehicleState) -> None:
        self.mission.start(state)

    @property
    def landing(self) -> bool:
        return self.mission.landing

    def lifts_off(self, state: VehicleState) -> bool:
        return self.mission.auto.climbing

    def setpoint(self, state: VehicleState) -> np.ndarray:
        return self.mission.step(state)

    def yaw(self, state: VehicleState) -> YawSetpoint | None:
        return self.mission.auto.yaw(state)

    def touched_down(self, state: VehicleState) -> None:
        self.mission.landed(state)
