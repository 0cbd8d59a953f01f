"""The plant's equations of motion: 6-DOF rigid body with quaternion attitude, actuator dynamics, ground
contact and failures, integrated with RK4. Built once as a CasADi Function (one call per physics step).

State x (25): position NED (3), velocity NED (3), quaternion body->NED (w, x, y, z) (4), body rates (3),
rotor speeds rad/s (4), tilts rad (4), surface deflections -1..1 (4).
Command (12): thrust fractions 0..1 (4), tilt set-points rad (4), deflection set-points -1..1 (4).
Parameters (39): per actuator an override flag (12) and value (12) in command units (failures that pin an
actuator), a per-actuator scale (12) (rotor: max thrust fraction; tilt servo: slew-rate fraction; surface:
effectiveness), and the wind in NED (3).
"""

from __future__ import annotations

import casadi as ca

from aircraft.actuators import CHANNELS, ROTORS, SURFACES, TILTS
from aircraft.airframe import Airframe
from aircraft.frames import quaternion_derivative, rotation_from_quaternion
from aircraft.rotors import thrust_from_speed
from aircraft.wrench import body_wrench
from sim_bridge.ground import gear_contact

POSITION, VELOCITY, QUATERNION, RATES = slice(0, 3), slice(3, 6), slice(6, 10), slice(10, 13)
ROTOR_SPEED, TILT, SURFACE = slice(13, 17), slice(17, 21), slice(21, 25)
STATE_SIZE = 25
COMMAND_SIZE = CHANNELS
OVERRIDE_FLAG, OVERRIDE_VALUE, SCALE, WIND = slice(0, 12), slice(12, 24), slice(24, 36), slice(36, 39)
PARAMETER_SIZE = 39


def effective_command(airframe: Airframe, command: ca.SX, parameters: ca.SX) -> ca.SX:
    """Commands after failures (overrides, rotor thrust caps) and physical range limits."""
    flag = parameters[OVERRIDE_FLAG]
    pinned = ca.if_else(flag > 0.5, parameters[OVERRIDE_VALUE], command)  # elementwise on SX vectors
    scale = parameters[SCALE]
    rotors = ca.fmin(ca.fmax(pinned[ROTORS], 0), scale[ROTORS])
    tilts = ca.fmin(ca.fmax(pinned[TILTS], airframe.tilt_min), airframe.tilt_max)
    surfaces = ca.fmin(ca.fmax(pinned[SURFACES], -1), 1)
    return ca.vertcat(rotors, tilts, surfaces)


def actuator_derivatives(airframe: Airframe, state: ca.SX, command: ca.SX, parameters: ca.SX) -> ca.SX:
    """d/dt of rotor speeds (first order, tau_up / tau_down), tilts (first order + slew limit), surfaces."""
    a = airframe
    cmd = effective_command(a, command, parameters)
    speed = state[ROTOR_SPEED]
    speed_target = a.rotor_speed_max * ca.sqrt(cmd[ROTORS])
    tau = ca.if_else(speed_target > speed, a.motor_tau_up, a.motor_tau_down)
    speed_dot = (speed_target - speed) / tau
    slew = a.servo_rate_max * parameters[SCALE][TILTS]
    tilt_dot = ca.fmin(ca.fmax((cmd[TILTS] - state[TILT]) / a.servo_tau, -slew), slew)
    surface_dot = (cmd[SURFACES] - state[SURFACE]) / a.surface_tau
    return ca.vertcat(speed_dot, tilt_dot, surface_dot)


def state_derivative(
    airframe: Airframe, state: ca.SX, command: ca.SX, parameters: ca.SX
) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
    """x_dot, the specific force in body axes (what an accelerometer reads), airspeed and ground contact flag."""
    a = airframe
    velocity, quaternion, rates = state[VELOCITY], state[QUATERNION], state[RATES]
    rotation = rotation_from_quaternion(quaternion)
    v_air_body = rotation.T @ (velocity - parameters[WIND])
    thrusts = thrust_from_speed(a, state[ROTOR_SPEED])
    force, moment = body_wrench(
        a, thrusts, state[TILT], state[SURFACE], v_air_body, rates, surface_scale=parameters[SCALE][SURFACES]
    )
    contact_force, contact_moment, touching = gear_contact(a, state[POSITION], velocity, rotation, rates)
    specific_force = (force + rotation.T @ contact_force) / a.mass
    acceleration = (rotation @ force + contact_force) / a.mass + ca.vertcat(0, 0, a.gravity)
    inertia = ca.diag(ca.DM(a.inertia_diag))
    angular_acceleration = ca.solve(inertia, moment + contact_moment - ca.cross(rates, inertia @ rates))
    x_dot = ca.vertcat(
        velocity,
        acceleration,
        quaternion_derivative(quaternion, rates),
        angular_acceleration,
        actuator_derivatives(a, state, command, parameters),
    )
    return x_dot, specific_force, ca.norm_2(v_air_body), touching


def build_step_function(airframe: Airframe, dt: float) -> ca.Function:
    """step(x, command, parameters) -> (x_next, specific_force_body, airspeed, on_ground) after one RK4 step.

    The other outputs are those of `build_output_function` at x_next (they depend on the state only), so the
    sensors sent for step k+1 describe the state sent for step k+1. The quaternion is renormalised each step.
    """
    x = ca.SX.sym("x", STATE_SIZE)
    u = ca.SX.sym("command", COMMAND_SIZE)
    p = ca.SX.sym("parameters", PARAMETER_SIZE)

    def f(state: ca.SX) -> ca.SX:
        return state_derivative(airframe, state, u, p)[0]

    k1 = f(x)
    k2 = f(x + dt / 2 * k1)
    k3 = f(x + dt / 2 * k2)
    k4 = f(x + dt * k3)
    x_next = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    q = x_next[QUATERNION]
    x_next = ca.vertcat(x_next[0:6], q / ca.norm_2(q), x_next[10:])
    specific_force, airspeed, touching = build_output_function(airframe)(x_next, u, p)
    return ca.Function(
        "plant_step",
        [x, u, p],
        [x_next, specific_force, airspeed, touching],
        ["x", "command", "parameters"],
        ["x_next", "specific_force", "airspeed", "on_ground"],
    )


def build_output_function(airframe: Airframe) -> ca.Function:
    """outputs(x, command, parameters) -> (specific_force_body, airspeed, on_ground) at state x."""
    x = ca.SX.sym("x", STATE_SIZE)
    u = ca.SX.sym("command", COMMAND_SIZE)
    p = ca.SX.sym("parameters", PARAMETER_SIZE)
    _, specific_force, airspeed, touching = state_derivative(airframe, x, u, p)
    return ca.Function(
        "plant_outputs", [x, u, p], [specific_force, airspeed, touching],
        ["x", "command", "parameters"], ["specific_force", "airspeed", "on_ground"],
    )  # fmt: skip
