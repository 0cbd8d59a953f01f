"""Offboard attitude set-points flown by the attitude loop and the allocation with the velocity controller out of
the loop (docs/mavlink.md, "Offboard"): the `VelocityCommand` an `AttitudeTarget` stands for.

The thrust is mapped as PX4 maps SET_ATTITUDE_TARGET's thrust for a VTOL in multicopter mode: a collective thrust
along body -z, 0..1 of the rotors' full thrust (thrust_body = (0, 0, -thrust)), with the rotors upright (tilts 0).
Body rates (when the attitude is ignored) become the attitude set-point whose P law asks for those rates: the
current attitude plus the Euler rates over the attitude gain.
"""

from __future__ import annotations

import numpy as np

from autopilot.control.attitude import AttitudeGains, euler_rates
from autopilot.control.velocity_command import VelocityCommand
from autopilot.topics.attitude_target import AttitudeTarget

ATTITUDE_MODE = "offboard attitude"


def attitude_euler_sp(target: AttitudeTarget, euler: np.ndarray, body_rates_sp: np.ndarray | None,
                      gains: AttitudeGains) -> np.ndarray:  # fmt: skip
    """The Euler set-point (rad) for the attitude loop flying with `gains`: the target's attitude, or the one its
    body rates ask for."""
    if target.euler is not None or body_rates_sp is None:
        return euler.copy() if target.euler is None else target.euler.copy()
    return euler + euler_rates(euler, body_rates_sp) / np.array(gains.attitude)


def attitude_command(target: AttitudeTarget, euler: np.ndarray, collective_max: float,
                     gains: AttitudeGains) -> VelocityCommand:  # fmt: skip
    """What the attitude loop (with `gains`) and the allocator fly for `target`; `collective_max` is the rotors'
    full thrust (N)."""
    return VelocityCommand(euler_sp=attitude_euler_sp(target, euler, target.body_rates, gains),
                           tilt_sp=np.zeros(4), force_sp_body=np.array([0.0, 0.0, -target.thrust * collective_max]),
                           yaw_by_tilt=True, mode=ATTITUDE_MODE)  # fmt: skip
