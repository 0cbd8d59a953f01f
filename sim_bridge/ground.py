"""Flat ground at z = 0 (NED): a spring-damper with smooth Coulomb friction under each landing-gear foot."""

from __future__ import annotations

import casadi as ca

from aircraft.airframe import Airframe


def gear_contact(
    airframe: Airframe, position_ned: ca.SX, velocity_ned: ca.SX, rotation_ib: ca.SX, rates_body: ca.SX
) -> tuple[ca.SX, ca.SX, ca.SX]:
    """Ground reaction: force in NED (N), moment in body FRD (N m), and 1 when any foot touches.

    Per foot at body offset r: penetration d = z of the foot; normal force N = max(0, k d + c dz/dt)
    while d > 0; friction -mu N v_t / sqrt(|v_t|^2 + v_eps^2) against the foot's horizontal velocity v_t.
    """
    a = airframe
    force = ca.SX.zeros(3)
    moment = ca.SX.zeros(3)
    touching = ca.SX(0)
    for point in a.gear_points:
        r = ca.DM(point)
        foot_position = position_ned + rotation_ib @ r
        foot_velocity = velocity_ned + rotation_ib @ ca.cross(rates_body, r)
        depth = foot_position[2]
        in_contact = depth > 0
        normal = ca.if_else(in_contact, ca.fmax(0, a.gear_stiffness * depth + a.gear_damping * foot_velocity[2]), 0)
        slip = ca.sqrt(foot_velocity[0] ** 2 + foot_velocity[1] ** 2 + a.gear_friction_speed**2)
        foot_force = ca.vertcat(
            -a.gear_friction * normal * foot_velocity[0] / slip,
            -a.gear_friction * normal * foot_velocity[1] / slip,
            -normal,
        )
        force = force + foot_force
        moment = moment + ca.cross(r, rotation_ib.T @ foot_force)
        touching = ca.fmax(touching, in_contact)
    return force, moment, touching


def resting_height(airframe: Airframe) -> float:
    """Down position (m, negative = above ground) of the centre of gravity when resting level on the gear."""
    lowest = max(point[2] for point in airframe.gear_points)
    feet = sum(1 for point in airframe.gear_points if point[2] == lowest)
    static_compression = airframe.mass * airframe.gravity / (feet * airframe.gear_stiffness)
    return -(lowest - static_compression)
