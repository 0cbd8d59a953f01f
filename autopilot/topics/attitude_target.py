"""An Offboard attitude set-point as the commander hands it to the flight controller (PX4's
vehicle_attitude_setpoint): the attitude loop and the allocation fly it with the velocity controller out of the loop."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ATTITUDE_CLIMB = 1.0  # m/s: the climb (or descent) an Offboard thrust above (below) hover stands for


@dataclass(frozen=True)
class AttitudeTarget:
    """An Offboard attitude set-point within its limits: Euler angles (rad) or body rates (rad/s), thrust 0..1."""

    euler: np.ndarray | None
    body_rates: np.ndarray | None
    thrust: float

    def climb(self, hover_fraction: float) -> np.ndarray:
        """The velocity set-point (NED) the thrust stands for: a lift-off above hover thrust, a descent (which the
        land detector watches) below it; the velocity controller does not fly it."""
        return np.array([0.0, 0.0, -ATTITUDE_CLIMB if self.thrust > hover_fraction else ATTITUDE_CLIMB])
