"""PX4's manual modes flown with MANUAL_CONTROL as a virtual RC (docs/mavlink.md "Manual control"): Position
(POSCTL) and Altitude (ALTCTL), sticks to velocity set-points.

    x  pitch stick, -1..1: forward (+) / back, in the sticks' frame
    y  roll stick, -1..1: right (+) / left
    z  throttle, 0..1 (MAVLink 0..1000), 0.5 centre: climb above centre up to MPC_Z_VEL_MAX_UP, descend below it
       down to MPC_Z_VEL_MAX_DN; centred: hold the altitude
    r  yaw stick, -1..1: yaw rate up to MPC_MAN_Y_MAX from the nose; centred, the turn is stopped and the heading
       where it stopped is held, as PX4's heading lock (docs/autopilot.md section 6); the sticks' frame is that
       heading

Position: horizontal velocity up to MPC_VEL_MANUAL; centred horizontal sticks brake, then hold the position.
Altitude: the same horizontal velocity with no position hold (centred sticks: zero velocity, the vehicle may drift);
the altitude held as in Position. Sticks within MPC_HOLD_DZ of centre are centred; beyond it they are rescaled.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigator.flight_modes import OFFBOARD_TAKEOFF_CLIMB, FlightMode
from autopilot.navigator.guidance import limit_norm, ramp, vertical_velocity
from autopilot.navigator.yaw_shaping import StickYaw
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.requests import ManualControlInput, Reply
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawSetpoint
from transport.mavlink import mavlink

POSITION, ALTITUDE = "Position", "Altitude"
TICK_S = 0.01
BRAKED_SPEED = 1.0  # m/s: a centred stick locks the position (or altitude) once slower than this
NO_MAVLINK_MANUAL_CONTROL = (0, 4)  # COM_RC_IN_MODE: RC only (there is no RC here), manual control disabled


def deadzone(stick: float, zone: float) -> float:
    """0 within `zone` of centre, rescaled to reach +-1 at full stick beyond it (PX4's MPC_HOLD_DZ)."""
    if abs(stick) <= zone:
        return 0.0
    return math.copysign((abs(stick) - zone) / (1.0 - zone), stick)


def climb_stick(throttle: float) -> float:
    """The throttle (0..1, 0.5 centre) as a vertical stick -1 (full down) .. 1 (full up)."""
    return min(max(2.0 * throttle - 1.0, -1.0), 1.0)


class ManualControl:
    """The latest sticks from MANUAL_CONTROL and when they arrived (for COM_RC_LOSS_T), taken when COM_RC_IN_MODE
    allows MAVLink."""

    def __init__(self, params: ParameterStore) -> None:
        self.params = params
        self.sticks = ManualControlInput()
        self.received_usec: int | None = None

    def _not_taken(self) -> str | None:
        mode = self.params.get_int("COM_RC_IN_MODE")
        return f"COM_RC_IN_MODE {mode} takes no MANUAL_CONTROL" if mode in NO_MAVLINK_MANUAL_CONTROL else None

    def receive(self, sticks: ManualControlInput, now_usec: int) -> Reply:
        if (why := self._not_taken()) is not None:
            return mavlink.MAV_RESULT_DENIED, f"MANUAL_CONTROL ignored: {why}"
        self.sticks = sticks
        self.received_usec = now_usec
        return mavlink.MAV_RESULT_ACCEPTED, None

    def fresh(self, now_usec: int) -> bool:
        timeout_usec = self.params["COM_RC_LOSS_T"] * 1e6
        return self.received_usec is not None and now_usec - self.received_usec <= timeout_usec

    def refusal(self, mode: str, now_usec: int) -> Reply | None:
        """Why Position or Altitude cannot be entered now (None: it can)."""
        if (why := self._not_taken()) is not None:
            return mavlink.MAV_RESULT_DENIED, f"{mode} denied: {why}"
        if not self.fresh(now_usec):
            return mavlink.MAV_RESULT_TEMPORARILY_REJECTED, (f"{mode} denied: no manual control (MANUAL_CONTROL) in "
                                                            f"the last {self.params['COM_RC_LOSS_T']:g} s")  # fmt: skip
        return None

    def stick_yaw_rate(self) -> float:
        """The latest yaw stick as a rate (rad/s, MPC_MAN_Y_MAX at full stick)."""
        return math.radians(self.params["MPC_MAN_Y_MAX"]) * deadzone(self.sticks.yaw, self.params["MPC_HOLD_DZ"])

    def yaw_rate(self, now_usec: int) -> float | None:
        """stick_yaw_rate, None without fresh sticks."""
        return self.stick_yaw_rate() if self.fresh(now_usec) else None

    def restart(self) -> None:
        self.received_usec = None


class StickMode(FlightMode):
    """Position (holds the position with centred sticks) or Altitude (does not)."""

    @property
    def detects_landing(self) -> bool:  # throttle down lands the vehicle
        return True

    def __init__(self, name: str, params: ParameterStore, manual: ManualControl) -> None:
        self.name = name
        self.params = params
        self.manual = manual
        self.stick_yaw = StickYaw()  # its heading is the sticks' frame (forward = x)
        self.yaw_setpoint: YawSetpoint | None = None  # this tick's (setpoint() makes it before yaw() reads it)
        self.hold_xy: np.ndarray | None = None
        self.hold_down: float | None = None
        self.velocity = np.zeros(3)

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
        if not centred or self.name == ALTITUDE:
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
