"""What a velocity controller (the MPC or the PID baseline) hands to the attitude loop and the allocator."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

YAW_FROM_COURSE_SPEED = 3.0  # m/s: above this horizontal set-point speed the nose follows the set-point's course


def setpoint_course(v_sp_north: float, v_sp_east: float) -> float | None:
    """The course (rad) both velocity controllers point the nose along (SPEC 4.3: psi_ref), or None when the
    horizontal set-point is too slow to have one (then the controller keeps its yaw)."""
    if math.hypot(v_sp_north, v_sp_east) <= YAW_FROM_COURSE_SPEED:
        return None
    return math.atan2(v_sp_east, v_sp_north)


@dataclass
class VelocityCommand:
    """Outer-loop output, refreshed at 100 Hz (SPEC section 4).

    euler_sp: attitude set-point (roll, pitch, yaw) in rad for the attitude loop.
    tilt_sp: tilt servo set-points chi_1..4 in rad, sent straight to the servos (not allocated).
    force_sp_body: total non-gravity force wanted in body FRD (N), the force part of the allocator's wrench.
    force_weights: how much each body force row matters to the allocator; a PID mode that leaves a force
        axis to the attitude (e.g. lift by pitch in forward flight) weighs it 0.
    yaw_by_tilt: hover yaw by differential tilt, as PX4 flies tiltrotors: the rotors' reaction torque alone
        (0.05 of thrust) cannot hold heading against a rotor jammed tilted.
    """

    euler_sp: np.ndarray = field(default_factory=lambda: np.zeros(3))
    tilt_sp: np.ndarray = field(default_factory=lambda: np.zeros(4))
    force_sp_body: np.ndarray = field(default_factory=lambda: np.zeros(3))
    force_weights: np.ndarray = field(default_factory=lambda: np.ones(3))
    yaw_by_tilt: bool = False  # let differential tilt take the yaw the rotors' thrust cannot make (PID, hover)
    mode: str = ""  # the controller's phase name, for telemetry and mode-switch counting
