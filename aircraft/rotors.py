"""Forces and moments of the four tilting rotors (paper eqs. 1-4; docs/model.md).

Rotor i at tilt chi_i (0 = thrust up, 90 deg = forward) and thrust T_i = c_F omega_i^2 gives, in body FRD:
  force          T_i u_i,               u_i = (sin chi_i, 0, -cos chi_i)
  thrust moment  r_i x (T_i u_i)
  reaction       d_i c_K omega_i^2 u_i = d_i (c_K / c_F) T_i u_i
"""

from __future__ import annotations

import math

import casadi as ca

from aircraft.airframe import Airframe

RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)  # a rotor's speed as an ESC reports it


def thrust_direction(tilt: ca.SX) -> ca.SX:
    """Unit thrust direction u(chi) in body FRD for one rotor at tilt chi (rad)."""
    return ca.vertcat(ca.sin(tilt), 0, -ca.cos(tilt))


def rotor_wrench(airframe: Airframe, thrusts: ca.SX, tilts: ca.SX) -> tuple[ca.SX, ca.SX]:
    """Body force (N) and moment (N m) of all rotors, given thrusts T_i (N) and tilts chi_i (rad)."""
    torque_per_thrust = airframe.torque_coefficient / airframe.thrust_coefficient
    forces, moments = [], []
    for i, (position, spin) in enumerate(zip(airframe.rotor_positions, airframe.spin_directions)):
        thrust_vector = thrusts[i] * thrust_direction(tilts[i])
        forces.append(thrust_vector)
        moments.append(ca.cross(ca.DM(position), thrust_vector) + spin * torque_per_thrust * thrust_vector)
    force, moment = sum(forces[1:], forces[0]), sum(moments[1:], moments[0])
    return force, moment


def thrust_from_speed(airframe: Airframe, rotor_speed: ca.SX) -> ca.SX:
    """T = c_F omega^2 (N) for rotor speeds in rad/s."""
    return airframe.thrust_coefficient * rotor_speed**2
