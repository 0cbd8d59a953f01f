"""Hold (PX4's AUTO.LOITER): brake and hold here; circle at cruise speed after a transition to fixed wing; or fly to
a DO_REPOSITION point and hold there."""

from __future__ import annotations

import numpy as np

from autopilot.navigator.auto_flight import FlyTo, HoldAt
from autopilot.navigator.mode import FlightMode, ModeContext
from autopilot.topics.flight_mode import PX4_AUTO_LOITER, PX4_MAIN_AUTO, ModeId
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawSetpoint
from transport.mavlink import mavlink

HOLD = "Hold"
REPOSITION_ACCEPTANCE = 1.0  # m: a DO_REPOSITION flies the leg to within this, then holds there
VTOL_FW, VTOL_MC = mavlink.MAV_VTOL_STATE_FW, mavlink.MAV_VTOL_STATE_MC  # 4, 3


class HoldMode(FlightMode):
    """AUTO.LOITER: brake and hold here; circle at cruise speed after a transition to fixed wing; or fly to a
    DO_REPOSITION point and hold there."""

    id = ModeId(HOLD, PX4_MAIN_AUTO, PX4_AUTO_LOITER)

    def __init__(self, context: ModeContext) -> None:
        self.tasks = context.tasks
        self.auto = context.auto
        self.repositioning = False  # flying self.auto's route (DO_REPOSITION)
        self.transition_target = VTOL_MC

    def activate(self, state: VehicleState) -> None:
        self.repositioning = False
        self.transition_target = VTOL_MC
        self.tasks.start_hold(state)

    def hold_at(self, xy: np.ndarray, down: float) -> None:
        """Hold this point (a takeoff ended over it)."""
        self.tasks.hold_xy = xy.copy()
        self.tasks.hold_down = down

    def reposition(self, state: VehicleState, position: np.ndarray, speed: float | None, yaw: float | None) -> None:
        """Fly to `position` and hold there; `yaw` (rad; None: the controllers' own rule) on the way and there."""
        self.repositioning = True
        self.auto.start(state, [FlyTo(position, REPOSITION_ACCEPTANCE, speed, yaw), HoldAt(position, None, yaw)])

    def transition(self, target: int, state: VehicleState) -> str | None:
        """MAV_CMD_DO_VTOL_TRANSITION in Hold: to FW circle at cruise speed, to MC brake and hover; what to say
        (None: already there)."""
        if target == self.transition_target:
            return None
        self.transition_target = target
        if target == VTOL_FW:
            self.tasks.start_fixed_wing_hold(state)
            return f"Transition to fixed wing: circling at {self.tasks.params['FW_AIRSPD_TRIM']:g} m/s"
        self.tasks.start_hold(state, down=self.tasks.hold_down)
        return "Transition to multicopter: braking to a hover"

    def setpoint(self, state: VehicleState) -> np.ndarray:
        return self.auto.step(state) if self.repositioning else self.tasks.hold(state)

    def yaw(self, state: VehicleState) -> YawSetpoint | None:
        return self.auto.yaw(state) if self.repositioning else None
