"""The attitude loop (docs/autopilot.md, paper "State Update"), defined once for the autopilot and the MPC.

P on attitude to a rate set-point, PD on rates to an angular-acceleration demand:
    rate_sp   = K_att (Psi_sp - Psi)                         (yaw wrapped, paper eq. for Psi_dot_sp; limited
                                                              smoothly to |rate| <= pi)
    accel_des = K_p (rate_sp - rate) + K_d (rate_prev - rate)   (paper eq. for tau)
in ZYX Euler-angle space (Psi = roll, pitch, yaw). The MPC predicts Psi_ddot = accel_des with exactly this law;
the autopilot maps it to body axes (omega_dot = E(Psi) Psi_ddot) and to a torque
tau = I omega_dot + omega x I omega.

Gains (tuned for I = diag(0.844, 1.347, 1.598) kg m^2 and the 12.5-25 ms motor lag; docs/autopilot.md):
roll/pitch: attitude 6 1/s, rate 20 1/s; yaw: attitude 3 1/s, rate 10 1/s; K_d = 0.1 x K_p on the
rate difference of consecutive loop ticks (4 ms apart at 250 Hz), a light damping of rate jitter. They are
parameters (MC_ROLL_P, MC_ROLLRATE_P, MC_ROLLRATE_D ...: autopilot/control/tuning.py), inputs of the compiled law
rather than constants in it, so a change applies at the next tick, here and in the MPC's model of this loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from aircraft.airframe import Airframe
from aircraft.frames import wrap_angle

MAX_RATE = (math.pi, math.pi, math.pi)  # rad/s, the rate set-point's smooth limit and the MPC's |Psi_dot| <= pi
GAIN_COUNT = 9  # the gains as one vector: attitude (3), rate_p (3), rate_d (3)
ATTITUDE_GAINS, RATE_P_GAINS, RATE_D_GAINS = slice(0, 3), slice(3, 6), slice(6, 9)  # within the vector


@dataclass(frozen=True)
class AttitudeGains:
    """Per-axis gains (roll, pitch, yaw)."""

    attitude: tuple[float, float, float] = (6.0, 6.0, 3.0)  # 1/s
    rate_p: tuple[float, float, float] = (20.0, 20.0, 10.0)  # 1/s
    rate_d: tuple[float, float, float] = (2.0, 2.0, 1.0)  # 1 (on the per-tick rate difference)

    def vector(self) -> np.ndarray:
        """The gains as the compiled laws take them (GAIN_COUNT numbers)."""
        return np.array((*self.attitude, *self.rate_p, *self.rate_d), dtype=float)


DEFAULT_GAINS = AttitudeGains()


def attitude_law(euler: ca.SX, euler_rate: ca.SX, euler_rate_prev: ca.SX, euler_sp: ca.SX, gains: ca.SX) -> ca.SX:
    """Euler-angle acceleration demand (rad/s^2) of the attitude loop (docs/autopilot.md); `gains` the
    GAIN_COUNT-vector of AttitudeGains.vector (symbols, or numbers)."""
    k_p, k_d = gains[RATE_P_GAINS], gains[RATE_D_GAINS]
    rate_sp = euler_rate_setpoint(euler, euler_sp, gains)
    return k_p * (rate_sp - euler_rate) + k_d * (euler_rate_prev - euler_rate)


def euler_rate_setpoint(euler: ca.SX, euler_sp: ca.SX, gains: ca.SX) -> ca.SX:
    """The Euler-angle rate set-point (rad/s) of the attitude loop's P law (docs/autopilot.md); `gains` as in
    attitude_law."""
    error = ca.vertcat(euler_sp[0] - euler[0], euler_sp[1] - euler[1], wrap_angle(euler_sp[2] - euler[2]))
    # Smooth rate limit (limit tanh(x / limit)): equal to the P law for small errors, bounded by the limit, and
    # with a gradient everywhere (a hard clamp left the MPC's QP blind to the set-point when saturated).
    limit = ca.DM(MAX_RATE)
    return limit * ca.tanh(gains[ATTITUDE_GAINS] * error / limit)


def euler_rate_matrix(euler: ca.SX) -> ca.SX:
    """E(Psi) with body rates omega = E(Psi) Psi_dot for ZYX Euler angles."""
    phi, theta = euler[0], euler[1]
    return ca.vertcat(
        ca.horzcat(1, 0, -ca.sin(theta)),
        ca.horzcat(0, ca.cos(phi), ca.sin(phi) * ca.cos(theta)),
        ca.horzcat(0, -ca.sin(phi), ca.cos(phi) * ca.cos(theta)),
    )


def build_attitude_function(airframe: Airframe) -> ca.Function:
    """torque(euler, body_rates, euler_rate_prev, euler_sp, gains) -> (torque_body N m, euler_rate) for the
    autopilot; gains as AttitudeGains.vector."""
    euler, rates, prev, sp = (ca.SX.sym(n, 3) for n in ("euler", "body_rates", "euler_rate_prev", "euler_sp"))
    gains = ca.SX.sym("gains", GAIN_COUNT)
    e_matrix = euler_rate_matrix(euler)
    euler_rate = ca.solve(e_matrix, rates)
    accel = attitude_law(euler, euler_rate, prev, sp, gains)
    inertia = ca.diag(ca.DM(airframe.inertia_diag))
    torque = inertia @ (e_matrix @ accel) + ca.cross(rates, inertia @ rates)
    return ca.Function("attitude_torque", [euler, rates, prev, sp, gains], [torque, euler_rate])


class AttitudeController:
    """The 250 Hz attitude loop: Euler set-point -> body torque set-point, remembering the previous rate."""

    def __init__(self, airframe: Airframe, gains: AttitudeGains = DEFAULT_GAINS) -> None:
        self._function = build_attitude_function(airframe)
        self._buffer, self._evaluate = self._function.buffer()
        self.euler = np.zeros(3)
        self.body_rates = np.zeros(3)
        self.euler_rate_prev = np.zeros(3)
        self.euler_sp = np.zeros(3)
        self.torque = np.zeros(3)
        self.euler_rate = np.zeros(3)
        self.gains = gains
        self._gains = gains.vector()
        for i, array in enumerate((self.euler, self.body_rates, self.euler_rate_prev, self.euler_sp, self._gains)):
            self._buffer.set_arg(i, memoryview(array))
        self._buffer.set_res(0, memoryview(self.torque))
        self._buffer.set_res(1, memoryview(self.euler_rate))
        self._started = False

    def set_gains(self, gains: AttitudeGains) -> None:
        """The gains from the next tick on (PX4 applies its attitude and rate gains in flight too)."""
        self.gains = gains
        self._gains[:] = gains.vector()

    def update(self, euler: np.ndarray, body_rates: np.ndarray, euler_sp: np.ndarray) -> np.ndarray:
        """Torque set-point (N m, body) for the current attitude and set-point."""
        self.euler[:] = euler
        self.body_rates[:] = body_rates
        self.euler_sp[:] = euler_sp
        if not self._started:  # first tick: no previous rate yet, so no derivative kick
            self._evaluate()
            self.euler_rate_prev[:] = self.euler_rate
            self._started = True
        self._evaluate()
        self.euler_rate_prev[:] = self.euler_rate
        return self.torque


def euler_rates(euler: np.ndarray, body_rates: np.ndarray) -> np.ndarray:
    """Psi_dot = E(Psi)^-1 omega for ZYX Euler angles (euler_rate_matrix, numerically)."""
    phi, theta = euler[0], euler[1]
    sf, cf, ct, tt = math.sin(phi), math.cos(phi), math.cos(theta), math.tan(theta)
    p, q, r = body_rates
    return np.array([p + sf * tt * q + cf * tt * r, cf * q - sf * r, (sf * q + cf * r) / ct])
