"""The shared aircraft model against hand calculations (issue 2: hand-checked numbers and moment signs)."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import fsolve

from aircraft.aerodynamics import aero_effectiveness, airflow, drag_coefficient, lift_coefficient, surface_moment
from aircraft.frames import euler_from_quaternion, quaternion_from_euler, rotation_from_euler, rotation_from_quaternion
from aircraft.rotors import rotor_wrench
from aircraft.wrench import actuator_wrench, body_wrench

ZERO3 = ca.DM.zeros(3)


def vec(value) -> np.ndarray:
    return np.asarray(ca.DM(value)).ravel()


def test_hover_needs_18_21_newton_per_rotor(airframe):
    assert airframe.hover_thrust_per_rotor == pytest.approx(18.21, abs=0.005)
    # At that thrust and zero tilt the rotors give exactly the weight upwards and no net moment.
    force, moment = rotor_wrench(airframe, [airframe.hover_thrust_per_rotor] * 4, [0.0] * 4)
    assert vec(force) == pytest.approx([0, 0, -airframe.mass * airframe.gravity], abs=1e-9)
    assert vec(moment) == pytest.approx([0, 0, 0], abs=1e-9)


def test_max_thrust_is_26_36_newton(airframe):
    assert airframe.thrust_max == pytest.approx(26.36, abs=0.01)


def test_level_flight_at_26_mps_trims_at_half_a_degree_with_6_7_newton_drag(airframe):
    speed, weight = 26.0, airframe.mass * airframe.gravity

    def residual(z):
        pitch, thrust = z  # level flight: pitch = alpha; all rotors forward (tilt 90 deg), total thrust
        rotation = rotation_from_euler(ca.vertcat(0, pitch, 0))
        v_body = rotation.T @ ca.DM([speed, 0, 0])
        force, _ = body_wrench(airframe, ca.DM([thrust / 4] * 4), ca.DM([math.pi / 2] * 4), ca.DM.zeros(4),
                               v_body, ZERO3)  # fmt: skip
        inertial = vec(rotation @ force) + [0, 0, weight]
        return [inertial[0], inertial[2]]

    alpha, thrust = fsolve(residual, [0.01, 5.0])
    assert math.degrees(alpha) == pytest.approx(0.5, abs=0.1)
    assert thrust == pytest.approx(6.7, abs=0.1)  # thrust = drag in level flight


@pytest.mark.parametrize("speed, expected", [(10.0, 0.0), (16.0, 0.25), (20.0, 0.69), (24.0, 0.99)])
def test_aero_effectiveness(airframe, speed, expected):
    assert float(aero_effectiveness(airframe, speed)) == pytest.approx(expected, abs=0.01)


def test_aero_effectiveness_is_clamped_to_unit_interval(airframe):
    values = [float(aero_effectiveness(airframe, v)) for v in np.linspace(0, 60, 121)]
    assert min(values) == 0.0 and max(values) <= 1.0
    assert values == sorted(values)


def test_lift_is_linear_below_stall_and_a_flat_plate_beyond(airframe):
    small = math.radians(4)
    assert float(lift_coefficient(airframe, small)) == pytest.approx(0.35 + 6.3025 * small, rel=1e-3)
    big = math.radians(60)
    assert float(lift_coefficient(airframe, big)) == pytest.approx(2 * math.sin(big) ** 2 * math.cos(big), rel=1e-3)
    k = 1 / (math.pi * 0.8 * (2.0**2 / 0.44))
    assert float(drag_coefficient(airframe, 0.0)) == pytest.approx(0.03 + k * 0.35**2, rel=1e-6)
    assert float(drag_coefficient(airframe, big)) == pytest.approx(2 * math.sin(big) ** 2, rel=1e-3)


def test_rotor_moment_signs_match_the_body_frame(airframe):
    thrust = 10.0
    hover = [0.0] * 4
    kq = airframe.torque_coefficient / airframe.thrust_coefficient
    for i, (x, y, _) in enumerate(airframe.rotor_positions):
        thrusts = [0.0] * 4
        thrusts[i] = thrust
        force, moment = (vec(v) for v in rotor_wrench(airframe, thrusts, hover))
        assert force == pytest.approx([0, 0, -thrust])
        # r x (0, 0, -T) = (-y T, x T, 0): a right rotor rolls left, a front rotor pitches up.
        assert moment[0] == pytest.approx(-y * thrust)
        assert moment[1] == pytest.approx(x * thrust)
        # Reaction torque d_i c_K/c_F T (0, 0, -1): rotors 1 and 3 (d = +1) yaw left, 2 and 4 yaw right.
        assert moment[2] == pytest.approx(-airframe.spin_directions[i] * kq * thrust)
    # Tilted forward (90 deg): a right rotor pushes the nose left (negative yaw), a left one right.
    forward = [math.pi / 2] * 4
    _, moment_right = rotor_wrench(airframe, [thrust, 0, 0, 0], forward)
    _, moment_left = rotor_wrench(airframe, [0, 0, 0, thrust], forward)
    assert vec(moment_right)[2] == pytest.approx(-0.5 * thrust)
    assert vec(moment_left)[2] == pytest.approx(0.5 * thrust)
    assert vec(moment_right)[0] == pytest.approx(kq * thrust)  # reaction torque now about x


def test_control_surface_moment_signs(airframe):
    v = ca.DM([20.0, 0, 0])
    q_bar = 0.5 * 1.225 * 400
    roll = vec(surface_moment(airframe, v, [1, 0, 0, 0]))
    assert roll == pytest.approx([q_bar * 0.036 * 2 * 0.1173 / 2, 0, 0])
    assert vec(surface_moment(airframe, v, [1, -1, 0, 0]))[0] == pytest.approx(2 * roll[0])
    assert vec(surface_moment(airframe, v, [0, 0, 1, 0]))[1] == pytest.approx(q_bar * 0.1364 * 0.22 * 0.556)
    assert vec(surface_moment(airframe, v, [0, 0, 0, 1]))[2] == pytest.approx(q_bar * 0.004 * 2 * 0.0881)


def test_rate_damping_opposes_rotation(airframe):
    v = ca.DM([26.0, 0, 0])
    _, moment = body_wrench(airframe, ca.DM.zeros(4), ca.DM.zeros(4), ca.DM.zeros(4), v, ca.DM([0.5, 0.5, 0.5]))
    assert all(m < 0 for m in vec(moment))


def test_model_is_differentiable_in_a_perfect_hover(airframe):
    """The MPC and allocation differentiate the model at v = 0: every derivative must be finite."""
    u, tilt, v, w = ca.SX.sym("u", 8), ca.SX.sym("tilt", 4), ca.SX.sym("v", 3), ca.SX.sym("w", 3)
    wrench = actuator_wrench(airframe, u, tilt, v, w)
    jacobian = ca.Function("j", [u, tilt, v, w], [ca.jacobian(wrench, ca.vertcat(u, tilt, v, w))])
    value = np.asarray(jacobian(np.full(8, 0.5), np.zeros(4), np.zeros(3), np.zeros(3)))
    assert np.all(np.isfinite(value))
    speed, alpha, beta = (float(x) for x in airflow(ca.DM([0, 0, 0])))
    assert (speed, alpha, beta) == pytest.approx((1e-3, 0.0, 0.0))


def test_quaternion_and_euler_rotations_agree():
    euler = (0.3, -0.2, 2.5)
    q = quaternion_from_euler(*euler)
    assert vec(rotation_from_quaternion(q)) == pytest.approx(vec(rotation_from_euler(euler)), abs=1e-12)
    assert vec(euler_from_quaternion(q)) == pytest.approx(euler, abs=1e-12)


@pytest.mark.parametrize(
    "velocity, alpha",
    [((15, 0, 0), 0.0), ((-15, 0, 0), math.pi), ((-15, 0, 1e-9), math.pi), ((-15, 0, -1e-9), -math.pi),
     ((10, 0, 10), math.pi / 4), ((0, 0, 5), math.pi / 2), ((1e-5, 0, 0), 0.0)],
)  # fmt: skip
def test_angle_of_attack_is_atan2_everywhere_including_backward_flow(velocity, alpha):
    assert float(airflow(ca.DM(velocity))[1]) == pytest.approx(alpha, abs=1e-6)
