"""The vehicle's total body wrench: rotors + wing + control surfaces (+ gravity), written once.

The plant integrates it, the allocation differentiates `actuator_wrench` with respect to the
actuators, and the MPC predicts with `body_force`. Gravity is kept separate because the plant and the
MPC add it in the inertial frame.
"""

from __future__ import annotations

import casadi as ca

from aircraft.actuators import ALLOCATED_ROTORS, ALLOCATED_SURFACES
from aircraft.aerodynamics import surface_moment, wing_wrench
from aircraft.airframe import Airframe
from aircraft.rotors import rotor_wrench

# Names of the allocated actuators, in the allocation order of aircraft/actuators.py (docs/autopilot.md).
ALLOCATED_ACTUATORS = ("rotor1", "rotor2", "rotor3", "rotor4", "aileron_left", "aileron_right", "elevator", "rudder")


def body_wrench(
    airframe: Airframe,
    thrusts: ca.SX,
    tilts: ca.SX,
    deflections: ca.SX,
    v_air_body: ca.SX,
    rates_body: ca.SX,
    surface_scale: ca.SX | None = None,
) -> tuple[ca.SX, ca.SX]:
    """Aerodynamic and propulsive force (N) and moment (N m) in body FRD, gravity excluded.

    thrusts: rotor thrusts T_i (N); tilts: chi_i (rad); deflections: (aileron L, aileron R, elevator,
    rudder) in -1..1; surface_scale: per-surface effectiveness (1 = healthy, for failures).
    """
    f_rotor, m_rotor = rotor_wrench(airframe, thrusts, tilts)
    f_wing, m_wing = wing_wrench(airframe, v_air_body, rates_body)
    effective = deflections if surface_scale is None else deflections * surface_scale
    m_surface = surface_moment(airframe, v_air_body, effective)
    return f_rotor + f_wing, m_rotor + m_wing + m_surface


def actuator_wrench(airframe: Airframe, actuators: ca.SX, tilts: ca.SX, v_air_body: ca.SX, rates_body: ca.SX) -> ca.SX:
    """6-vector (force, moment) of the allocated actuators u = (u1..u4 thrust fractions 0..1, daL, daR, de, dr)."""
    thrusts = actuators[ALLOCATED_ROTORS] * airframe.thrust_max
    deflections = actuators[ALLOCATED_SURFACES]
    force, moment = body_wrench(airframe, thrusts, tilts, deflections, v_air_body, rates_body)
    return ca.vertcat(force, moment)


def gravity_body(airframe: Airframe, rotation_ib: ca.SX) -> ca.SX:
    """Weight expressed in body axes: R_IB^T (0, 0, m g)."""
    return rotation_ib.T @ ca.vertcat(0, 0, airframe.mass * airframe.gravity)
