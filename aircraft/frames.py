"""Rotations between the inertial NED frame and the body FRD frame, and angles wrapped to (-pi, pi].

Written with CasADi operations so each function works on Python floats, numpy-free DM values and
CasADi symbols alike (the plant, the MPC and the allocation share them).
"""

from __future__ import annotations

import math

import casadi as ca


def wrap_angle(angle: ca.SX) -> ca.SX:
    """Angle wrapped to (-pi, pi], smooth where it matters (works on floats and symbols)."""
    return ca.atan2(ca.sin(angle), ca.cos(angle))


def wrap(angle: float) -> float:
    """wrap_angle on a plain float (rad)."""
    return math.atan2(math.sin(angle), math.cos(angle))


def rotation_from_quaternion(q: ca.SX) -> ca.SX:
    """R_IB (body -> NED) from a unit quaternion q = (w, x, y, z)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    return ca.vertcat(
        ca.horzcat(1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        ca.horzcat(2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        ca.horzcat(2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    )


def rotation_from_euler(euler: ca.SX) -> ca.SX:
    """R_IB from ZYX Euler angles (roll phi, pitch theta, yaw psi): R = Rz(psi) Ry(theta) Rx(phi)."""
    phi, theta, psi = euler[0], euler[1], euler[2]
    cf, sf = ca.cos(phi), ca.sin(phi)
    ct, st = ca.cos(theta), ca.sin(theta)
    cp, sp = ca.cos(psi), ca.sin(psi)
    return ca.vertcat(
        ca.horzcat(ct * cp, sf * st * cp - cf * sp, cf * st * cp + sf * sp),
        ca.horzcat(ct * sp, sf * st * sp + cf * cp, cf * st * sp - sf * cp),
        ca.horzcat(-st, sf * ct, cf * ct),
    )


def quaternion_derivative(q: ca.SX, rates_body: ca.SX) -> ca.SX:
    """dq/dt = 1/2 q (x) (0, omega) for body rates omega = (p, q, r) in rad/s."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    p, qq, r = rates_body[0], rates_body[1], rates_body[2]
    return 0.5 * ca.vertcat(
        -x * p - y * qq - z * r,
        w * p + y * r - z * qq,
        w * qq + z * p - x * r,
        w * r + x * qq - y * p,
    )


def euler_from_quaternion(q: ca.SX) -> ca.SX:
    """ZYX Euler angles (roll, pitch, yaw) in rad from q = (w, x, y, z)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    roll = ca.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    sin_pitch = ca.fmin(1.0, ca.fmax(-1.0, 2 * (w * y - z * x)))
    pitch = ca.asin(sin_pitch)
    yaw = ca.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return ca.vertcat(roll, pitch, yaw)


def quaternion_from_euler(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of ZYX Euler angles (rad)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    )


def rotation_rows(w: float, x: float, y: float, z: float) -> tuple[tuple[float, float, float], ...]:
    """R_IB of a unit quaternion as three row tuples, in plain Python for per-step code (no CasADi, no numpy)."""
    return (
        (1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    )
