"""Wing and control-surface aerodynamics (paper section "Aerodynamics"; docs/model.md with its deviations).

All functions use CasADi operations, so they evaluate on floats and on CasADi symbols.
Angles in rad, speeds in m/s, forces in N, moments in N m, body axes FRD.
"""

from __future__ import annotations

import casadi as ca

from aircraft.airframe import Airframe

# Airspeed below which the flow direction is undefined: V and alpha are regularised with it so that
# their derivatives stay finite in a perfect hover (the MPC and the allocation differentiate them).
AIRSPEED_FLOOR = 1e-3


def airflow(v_air_body: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
    """Airspeed V, angle of attack alpha = atan2(w, u) and sideslip beta = asin(v / V) of the body airspeed."""
    u, v, w = v_air_body[0], v_air_body[1], v_air_body[2]
    airspeed = ca.sqrt(u * u + v * v + w * w + AIRSPEED_FLOOR**2)
    # atan2 has no derivative at u = w = 0: there (within the floor) the flow is taken as coming from ahead.
    # Elsewhere it is the exact atan2, including backward flow (alpha near +-pi, where the flat-plate
    # coefficients are continuous across the branch cut).
    in_still_air = u * u + w * w < AIRSPEED_FLOOR**2
    alpha = ca.atan2(w, ca.if_else(in_still_air, AIRSPEED_FLOOR, u))
    beta = ca.asin(v / airspeed)
    return airspeed, alpha, beta


def aero_effectiveness(airframe: Airframe, airspeed: ca.SX) -> ca.SX:
    """e(V) in [0, 1]: how much of the wing's aerodynamics act (authors' code; docs/model.md)."""
    a = airframe
    s1 = 0.5 * (1 + ca.tanh((airspeed - a.eff_v_onset) / a.eff_width))
    s2 = 0.5 * (1 + ca.tanh((airspeed - a.eff_v_full) / a.eff_width))
    e = s2 + (1 - s2) * s1 * a.eff_ramp_gain * (airspeed - a.eff_v_zero) / a.eff_ramp_span
    return ca.fmin(1.0, ca.fmax(0.0, e))


def stall_blend(airframe: Airframe, alpha: ca.SX) -> ca.SX:
    """Beard & McLain sigmoid: 0 in the linear range, 1 beyond stall (|alpha| > alpha0)."""
    m, a0 = airframe.stall_blend_rate, airframe.stall_alpha0
    below = ca.exp(-m * (alpha - a0))
    above = ca.exp(m * (alpha + a0))
    return (1 + below + above) / ((1 + below) * (1 + above))


def lift_coefficient(airframe: Airframe, alpha: ca.SX) -> ca.SX:
    """C_L: linear C_L0 + C_La alpha, blended to a flat plate 2 sign(a) sin^2(a) cos(a) beyond stall."""
    sigma = stall_blend(airframe, alpha)
    linear = airframe.CL0 + airframe.CL_alpha * alpha
    flat_plate = 2 * ca.sign(alpha) * ca.sin(alpha) ** 2 * ca.cos(alpha)
    return (1 - sigma) * linear + sigma * flat_plate


def drag_coefficient(airframe: Airframe, alpha: ca.SX) -> ca.SX:
    """C_D: polar C_D0 + k C_L,lin^2, blended to 2 sin^2(alpha) beyond stall (docs/model.md: deviates from the paper)."""
    sigma = stall_blend(airframe, alpha)
    linear_lift = airframe.CL0 + airframe.CL_alpha * alpha
    polar = airframe.CD0 + airframe.induced_drag_factor * linear_lift**2
    return (1 - sigma) * polar + sigma * 2 * ca.sin(alpha) ** 2


def wing_wrench(airframe: Airframe, v_air_body: ca.SX, rates_body: ca.SX) -> tuple[ca.SX, ca.SX]:
    """Body force and damping moment of the wing, scaled by e(V).

    F_x = e qS(-C_D cos a + C_L sin a), F_z = e qS(-C_D sin a - C_L cos a), F_y = e qS C_Yb b;
    damping L = e qS b C_lp (p b / 2V) = e rho V S b^2 C_lp p / 4 (likewise M with c and q, N with b and r).
    """
    a = airframe
    airspeed, alpha, beta = airflow(v_air_body)
    e = aero_effectiveness(a, airspeed)
    q_s = 0.5 * a.air_density * airspeed**2 * a.wing_area
    c_l, c_d = lift_coefficient(a, alpha), drag_coefficient(a, alpha)
    cos_a, sin_a = ca.cos(alpha), ca.sin(alpha)
    force = e * q_s * ca.vertcat(-c_d * cos_a + c_l * sin_a, a.CY_beta * beta, -c_d * sin_a - c_l * cos_a)
    damping = 0.25 * a.air_density * airspeed * a.wing_area
    moment = (
        e
        * damping
        * ca.vertcat(
            a.wing_span**2 * a.Cl_p * rates_body[0],
            a.mean_chord**2 * a.Cm_q * rates_body[1],
            a.wing_span**2 * a.Cn_r * rates_body[2],
        )
    )
    return force, moment


def surface_moment(airframe: Airframe, v_air_body: ca.SX, deflections: ca.SX) -> ca.SX:
    """Moments of (aileron L, aileron R, elevator, rudder) deflections in -1..1 (paper; not scaled by e(V)).

    L = q S_a b C_la (d_aL - d_aR) / 2, M = q S_e c C_me d_e, N = q S_r b C_nr d_r.
    """
    a = airframe
    q_bar = 0.5 * a.air_density * ca.sumsqr(v_air_body)
    return q_bar * ca.vertcat(
        a.aileron_area * a.wing_span * a.aileron_effectiveness * (deflections[0] - deflections[1]) / 2,
        a.elevator_area * a.mean_chord * a.elevator_effectiveness * deflections[2],
        a.rudder_area * a.wing_span * a.rudder_effectiveness * deflections[3],
    )
