"""Position and Altitude's shared flight (PX4's manual modes flown with MANUAL_CONTROL as a virtual RC, docs/mavlink.md
"Manual control"): the sticks to velocity set-points.

    x  pitch stick: forward (+) / back, in the sticks' frame; y  roll stick: right (+) / left
    z  throttle, 0.5 centre: climb above centre up to MPC_Z_VEL_MAX_UP, descend below it down to MPC_Z_VEL_MAX_DN;
       centred: hold the altitude
    r  yaw stick: yaw rate up to MPC_MAN_Y_MAX from the nose; centred, the turn is stopped and the heading where it
       stopped is held, as PX4's heading lock (docs/mavlink.md, Yaw); the sticks' frame is that heading

Horizontal velocity up to MPC_VEL_MANUAL; centred horizontal sticks brake, then (Position only) hold the position.
Sticks within MPC_HOLD_DZ of centre are centred; beyond it they are rescaled.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigator.guidance import TICK_S, limit_norm, ramp, vertical_velocity
from autopilot.navigator.manual_control import climb_stick, deadzone
from autopilot.navigator.mode import OFFBOARD_TAKEOFF_CLIMB, FlightMode, ModeContext, ModeEntry
from autopilot.navigator.yaw_shaping import StickYaw
from autopilot.topics.requests import Reply
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawSetpoint

BRAKED_SPEED = 1.0  # m/s: a centred stick locks the position (or altitude) once slower than this


class StickMode(FlightMode):
    """Flown by the sticks: Position (holds the position with centred sticks) or Altitude (does not)."""

    holds_position = True

    @property
    def detects_landing(self) -> bool:  # throttle down lands the vehicle
        return True

    def __init__(self, context: ModeContext) -> None:
        self.params = context.params
        self.manual = context.manual
        self.stick_yaw = StickYaw()  # its heading is the sticks' frame (forward = x)
        self.yaw_setpoint: YawSetpoint | None = None  # this tick's (setpoint() makes it before yaw() reads it)
        self.hold_xy: np.ndarray | None = None
        self.hold_down: float | None = None
        self.velocity = np.zeros(3)

    def entry_refusal(self, entry: ModeEntry) -> Reply | None:
        return self.manual.refusal(self.id.name, entry.now_usec)

    def activate(self, state: VehicleState) -> None:
        self.stick_yaw.reset(float(state.euler[2]))
        self.yaw_setpoint = YawSetpoint(self.stick_yaw.heading)
        self.hold_xy = None
        self.hold_down = None
        self.velocity = state.velocity_ned.copy()

    def lifts_off(self, state: VehicleState) -> bool:
        return bool(self.setpoint(state)[2] < -OFFBOARD_TAKEOFF_CLIMB)

    def setpoint(self, state: VehicleState) -> np.ndarray:
        p, sticks = self.params, self.manual.sticks
        zone = p["MPC_HOLD_DZ"]
        self.yaw_setpoint = self.stick_yaw.update(self.manual.stick_yaw_rate(), float(state.euler[2]),
                                                  float(state.body_rates[2]))  # fmt: skip
        forward, right = deadzone(sticks.pitch, zone), deadzone(sticks.roll, zone)
        c, s = math.cos(self.stick_yaw.heading), math.sin(self.stick_yaw.heading)
        horizontal = limit_norm(np.array([c * forward - s * right, s * forward + c * right]), 1.0) * p["MPC_VEL_MANUAL"]
        horizontal = self._horizontal_hold(state, horizontal, forward == right == 0.0)
        climb = deadzone(climb_stick(sticks.throttle), zone)
        down = -climb * (p["MPC_Z_VEL_MAX_UP"] if climb > 0 else p["MPC_Z_VEL_MAX_DN"])
        down = self._altitude_hold(state, down, climb == 0.0)
        self.velocity = ramp(self.velocity, np.array([*horizontal, down]), p["MPC_ACC_HOR"], TICK_S)
        return self.velocity.copy()

    def yaw(self, state: VehicleState) -> YawSetpoint | None:
        return self.yaw_setpoint  # this tick's, from setpoint()

    def _horizontal_hold(self, state: VehicleState, wanted: np.ndarray, centred: bool) -> np.ndarray:
        if not centred or not self.holds_position:
            self.hold_xy = None
            return wanted
        if self.hold_xy is None and math.hypot(*state.velocity_ned[0:2]) < BRAKED_SPEED:
            self.hold_xy = state.position_ned[0:2].copy()
        if self.hold_xy is None:
            return np.zeros(2)
        p = self.params
        return limit_norm(p["MPC_XY_P"] * (self.hold_xy - state.position_ned[0:2]), p["MPC_XY_CRUISE"])

    def _altitude_hold(self, state: VehicleState, wanted: float, centred: bool) -> float:
        if not centred:
            self.hold_down = None
            return wanted
        if self.hold_down is None and abs(float(state.velocity_ned[2])) < BRAKED_SPEED:
            self.hold_down = float(state.position_ned[2])
        if self.hold_down is None:
            return 0.0
        p = self.params
        return vertical_velocity(float(state.position_ned[2]), self.hold_down, p["MPC_Z_P"], p["MPC_Z_VEL_MAX_UP"],
                                 p["MPC_Z_VEL_MAX_DN"])  # fmt: skip
