"""MANUAL_CONTROL as PX4 takes it from a ground station's virtual joystick (docs/mavlink.md, "Modes"): the
latest sticks and when they came, for Position and Altitude (navigator/modes/sticks.py) and the COM_RC_LOSS_T
failsafe.

    x  pitch stick, -1..1: forward (+) / back, in the sticks' frame
    y  roll stick, -1..1: right (+) / left
    z  throttle, 0..1 (MAVLink 0..1000), 0.5 centre
    r  yaw stick, -1..1
"""

from __future__ import annotations

import math

from autopilot.storage.parameters import ParameterStore
from autopilot.topics.requests import ManualControlInput, Reply
from transport.mavlink import mavlink

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
