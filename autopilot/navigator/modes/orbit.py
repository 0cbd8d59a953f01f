"""Orbit (PX4's POSCTL.ORBIT navigation state): circle a centre for ever, started by MAV_CMD_DO_ORBIT (as a mode
alone it is refused: it needs the command's radius, speed and centre)."""

from __future__ import annotations

import numpy as np

from autopilot.navigator.auto_flight import ORBIT_RC_CONTROLLED, Circle
from autopilot.navigator.mode import FlightMode, ModeContext, ModeEntry
from autopilot.navigator.yaw_shaping import StickYaw
from autopilot.topics.flight_mode import PX4_MAIN_POSCTL, PX4_POSCTL_ORBIT, ModeId
from autopilot.topics.requests import Reply
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawSetpoint
from transport.mavlink import mavlink

ORBIT = "Orbit"


class OrbitMode(FlightMode):
    """POSCTL.ORBIT (PX4's Orbit navigation state): circle a centre for ever, the nose as the orbit's yaw behaviour asks.

    With RC_CONTROLLED the yaw stick turns the nose and it stays where the stick leaves it, as in Position mode
    (`stick_yaw_rate`: rad/s at a simulation time, None without fresh sticks)."""

    id = ModeId(ORBIT, PX4_MAIN_POSCTL, PX4_POSCTL_ORBIT)

    def __init__(self, context: ModeContext) -> None:
        self.auto = context.auto
        self.stick_yaw_rate = context.manual.yaw_rate
        self.stick_yaw = StickYaw()

    def entry_refusal(self, entry: ModeEntry) -> Reply | None:
        return mavlink.MAV_RESULT_DENIED, "Orbit: use MAV_CMD_DO_ORBIT (radius, speed, centre)"

    def start(self, state: VehicleState, circle: Circle) -> None:
        self.auto.start(state, [circle])
        self.stick_yaw.reset(float(state.euler[2]))

    def setpoint(self, state: VehicleState) -> np.ndarray:
        return self.auto.step(state)

    def yaw(self, state: VehicleState) -> YawSetpoint | None:
        target = self.auto.target
        if isinstance(target, Circle) and target.yaw_behaviour == ORBIT_RC_CONTROLLED:
            rate = self.stick_yaw_rate(state.time_usec)
            if rate is None:  # the nose is free until the sticks are back, and then locked where it is
                self.stick_yaw.reset(float(state.euler[2]))
                return None
            return self.stick_yaw.update(rate, float(state.euler[2]), float(state.body_rates[2]))
        return self.auto.yaw(state)
