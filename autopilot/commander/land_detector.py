"""PX4's land detector for this vehicle: when the commander takes a descent to be a touchdown."""

from __future__ import annotations

import math

from autopilot.topics.vehicle_state import VehicleState


class LandDetector:
    """Touchdown: a descent is asked for, but the vehicle has stopped moving down, and the collective thrust is
    below hover (the ground carries part of the weight), for 0.5 s. In the air a working controller does not
    hold still for half a second against a descent set-point of 0.3 m/s or more."""

    CONFIRM_S = 0.5
    MIN_DESCENT_SETPOINT = 0.3  # m/s
    MAX_VERTICAL_SPEED = 0.2  # m/s
    MAX_HORIZONTAL_SPEED = 1.0  # m/s
    THRUST_FRACTION_OF_HOVER = 0.9

    def __init__(self, hover_fraction: float) -> None:
        self.hover_fraction = hover_fraction
        self.since_usec: int | None = None

    def reset(self) -> None:
        self.since_usec = None

    def update(self, state: VehicleState, mean_thrust_fraction: float, time_usec: int, descent_sp: float) -> bool:
        on_ground_like = (
            descent_sp >= self.MIN_DESCENT_SETPOINT
            and abs(float(state.velocity_ned[2])) < self.MAX_VERTICAL_SPEED
            and math.hypot(state.velocity_ned[0], state.velocity_ned[1]) < self.MAX_HORIZONTAL_SPEED
            and mean_thrust_fraction < self.THRUST_FRACTION_OF_HOVER * self.hover_fraction
        )
        if not on_ground_like:
            self.since_usec = None
            return False
        if self.since_usec is None:
            self.since_usec = time_usec
        return time_usec - self.since_usec >= self.CONFIRM_S * 1e6
