"""What the autopilot knows of the vehicle each step: ground truth from HIL_STATE_QUATERNION (docs/model.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from aircraft.frames import rotation_rows
from transport.geodesy import LocalGeodetic


@dataclass
class VehicleState:
    """Navigation state in SI units: NED position and velocity, attitude, body rates, airspeed."""

    time_usec: int = 0
    position_ned: np.ndarray = field(default_factory=lambda: np.zeros(3))
    velocity_ned: np.ndarray = field(default_factory=lambda: np.zeros(3))
    quaternion: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    euler: np.ndarray = field(default_factory=lambda: np.zeros(3))  # roll, pitch, yaw (rad), ZYX
    body_rates: np.ndarray = field(default_factory=lambda: np.zeros(3))  # p, q, r (rad/s)
    airspeed: float = 0.0  # true airspeed (m/s)
    specific_force: np.ndarray = field(default_factory=lambda: np.zeros(3))  # accelerometer, body (m/s^2)
    valid: bool = False

    @property
    def time_s(self) -> float:
        return self.time_usec / 1e6

    @property
    def altitude_above_home(self) -> float:
        return -float(self.position_ned[2])

    def with_velocity(self, velocity_ned: np.ndarray) -> VehicleState:
        """This state with `velocity_ned` instead (the other arrays shared, as dataclasses.replace shares them; a
        third of its cost, at the controllers' 250 Hz)."""
        return VehicleState(
            time_usec=self.time_usec, position_ned=self.position_ned, velocity_ned=velocity_ned,
            quaternion=self.quaternion, euler=self.euler, body_rates=self.body_rates, airspeed=self.airspeed,
            specific_force=self.specific_force, valid=self.valid,
        )  # fmt: skip

    def rotation(self) -> np.ndarray:
        """R_IB (body -> NED)."""
        return np.array(rotation_rows(*self.quaternion.tolist()))


def euler_from_quaternion(w: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    """ZYX Euler angles (roll, pitch, yaw) in rad; plain-Python twin of aircraft.frames.euler_from_quaternion
    (which builds CasADi expressions) for the 400 Hz state update."""
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def update_from_hil_state(state: VehicleState, message, geodetic: LocalGeodetic, gravity: float) -> bool:
    """Fill `state` from a HIL_STATE_QUATERNION; False (state untouched) if any value is not finite."""
    qw, qx, qy, qz = message.attitude_quaternion
    rates = (message.rollspeed, message.pitchspeed, message.yawspeed)
    finite = math.isfinite  # spelt out, not all() over a generator: this runs at every 400 Hz step
    if not (finite(qw) and finite(qx) and finite(qy) and finite(qz)
            and finite(rates[0]) and finite(rates[1]) and finite(rates[2])):  # fmt: skip
        return False
    norm = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    if not 0.5 < norm < 1.5:
        return False
    w, x, y, z = qw / norm, qx / norm, qy / norm, qz / norm
    state.time_usec = message.time_usec
    state.position_ned[:] = geodetic.to_ned(message.lat * 1e-7, message.lon * 1e-7, message.alt * 1e-3)
    state.velocity_ned[:] = (message.vx * 0.01, message.vy * 0.01, message.vz * 0.01)
    state.quaternion[:] = (w, x, y, z)
    state.euler[:] = euler_from_quaternion(w, x, y, z)
    state.body_rates[:] = rates
    state.airspeed = message.true_airspeed * 0.01
    state.specific_force[:] = (
        message.xacc * gravity / 1000,
        message.yacc * gravity / 1000,
        message.zacc * gravity / 1000,
    )
    state.valid = True
    return True
