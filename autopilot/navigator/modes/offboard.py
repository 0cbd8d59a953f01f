"""Offboard (PX4's OFFBOARD): the client's velocity set-point, the velocity that flies to its position set-point, or
its attitude set-point (flown by the attitude loop, navigator/offboard_setpoint.py). Chosen only while set-points
come (COM_OF_LOSS_T); entered again while active, it goes on as it was."""

from __future__ import annotations

import numpy as np

from autopilot.navigator.mode import OFFBOARD_TAKEOFF_CLIMB, FlightMode, ModeContext, ModeEntry
from autopilot.topics.flight_mode import PX4_MAIN_OFFBOARD, ModeId
from autopilot.topics.requests import Reply
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawSetpoint
from transport.mavlink import mavlink

OFFBOARD = "Offboard"


class OffboardMode(FlightMode):
    """OFFBOARD: the client's velocity set-point, or the velocity that flies to its position set-point."""

    id = ModeId(OFFBOARD, PX4_MAIN_OFFBOARD)
    restarts_when_reentered = False

    @property
    def detects_landing(self) -> bool:  # a client may land the vehicle with its set-points
        return True

    def __init__(self, context: ModeContext) -> None:
        self.params = context.params
        self.tasks = context.tasks
        self.offboard = context.offboard
        self.hover_fraction = context.hover_fraction

    def entry_refusal(self, entry: ModeEntry) -> Reply | None:
        loss_s = self.params["COM_OF_LOSS_T"]
        if not self.offboard.fresh(entry.now_usec, loss_s):
            return mavlink.MAV_RESULT_TEMPORARILY_REJECTED, f"Offboard denied: no set-point in the last {loss_s:g} s"
        return None

    def activate(self, state: VehicleState) -> None:
        self.tasks.start_tracking(state)

    def setpoint(self, state: VehicleState) -> np.ndarray:
        if self.offboard.attitude is not None:  # flown by the attitude loop: what it asks of the land detector
            return self.offboard.attitude.climb(self.hover_fraction)
        if self.offboard.position is None:
            return self.offboard.velocity
        return self.tasks.track(state, self.offboard.position, self.offboard.velocity)

    def yaw(self, state: VehicleState) -> YawSetpoint | None:
        return self.offboard.yaw  # None while an attitude set-point flies (OffboardSetpoint clears it)

    def lifts_off(self, state: VehicleState) -> bool:
        return bool(self.setpoint(state)[2] < -OFFBOARD_TAKEOFF_CLIMB)
