"""The unified velocity MPC's optimal control problem (paper section "Model Predictive Control"; docs/mpc.md).

State x (16):  v (NED, m/s) | tilts chi_1..4 (rad) | Psi = (roll, pitch, yaw) | Psi_dot | Psi_dot_prev
Input u (11):  tilt rates chi_dot_1..4 (rad/s) | thrusts T_1..4 (N) | attitude set-point Psi_d (rad)
Model: v_dot = R(Psi) (sum_i T_i u(chi_i) + F_aero(R^T v)) / m + g e_z   (the shared aircraft model)
       chi_dot = input;  Psi_ddot = attitude_law(Psi, Psi_dot, Psi_dot_prev, Psi_d)  (the attitude loop's law)
       Psi_dot_prev(k+1) = Psi_dot(k)  (the previous step's rate, paper)
Cost per stage (paper eq. for J and Table 2): |v - v_sp,k|^2_Qref + |(phi - phi_ref, theta, psi - psi_ref)|^2_Qpsi
       + |Psi_dot - (0, 0, psi_rate_ref)|^2_Qpsidot + |T|^2_RT + |T cos(chi) - T_ref(V)|^2_Rlift + |chi_dot|^2_Rchi
       + |(phi_d - phi_ref, theta_d, psi_d - psi_d_ref)|^2_RPsi + J_soft,
       terminal |v_N - v_sp|^2_Qf. Every term is a squared residual (Gauss-Newton), J_soft = exp(s) included as
       (exp(s / 2))^2.
No flight-mode logic anywhere: the soft tilt cost alone keeps the rotors up at low speed.
The per-stage references (v_sp,k along the set-point's trajectory, and the coordinated-turn phi_ref,
psi_rate_ref, psi_d_ref) come from the controller (mpc/controller.py, docs/mpc.md, deviation 7); for a constant set-point
they are the paper's (v_sp, 0, 0, psi_ref).

Deviation (docs/mpc.md): the paper weighs the thrust itself, 0.025 T^2 (T in N). Measured with this plant:
- over a 0.25 s horizon that buys thrust with altitude (the velocity error a thrust deficit causes stays small
  within the horizon): a 21 m sink, 3.4 m/s, in the first 10 s of the acceleration test;
- weighing thrust beyond T_ref(V) = m g / 4 (1 - e(V)), the share of the weight the wing cannot carry at the
  stage's airspeed, removes the sink, but the tilt stalls near 50 deg at cruise (too little drive), and a
  10x weight that drives it to 80 deg also costs 0.6 m/s of cruise speed (it penalises the thrust that
  overcomes drag too).
So the weight acts on what the wing should take over: each rotor's lifting component T cos(chi) beyond
T_ref(V); a small weight on T itself keeps the least-effort preference. No mode switch: e(V) is the shared
model's smooth effectiveness.

Deviation (docs/mpc.md, deviation 6): the roll and pitch bound |phi|, |theta| <= pi/4 is soft, a smooth penalty in every
stage and at the end, not the paper's hard state bound: with x_0 fixed, a pitch already moving past the bound
faster than the attitude loop can stop it made every QP infeasible (accel-decel, 22.3 s: 3 failed solves, PID).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from aircraft.aerodynamics import aero_effectiveness, surface_moment
from aircraft.airframe import Airframe
from aircraft.frames import rotation_from_euler, wrap_angle
from aircraft.rotors import rotor_wrench
from aircraft.wrench import body_wrench
from autopilot.control.attitude import GAIN_COUNT, RATE_D_GAINS, attitude_law
from autopilot.control.velocity_command import has_course

NX, NU = 16, 11
V, CHI, PSI, PSI_DOT, PSI_DOT_PREV = slice(0, 3), slice(3, 7), slice(7, 10), slice(10, 13), slice(13, 16)
ROLL_PITCH, PSI_INDEX = slice(7, 9), 9  # within PSI: roll and pitch, yaw
CHI_DOT, THRUST, PSI_D = slice(0, 4), slice(4, 8), slice(8, 11)
ROLL_PITCH_D, PSI_D_INDEX = slice(8, 10), 10  # within PSI_D
# Parameters per stage: v_sp (3), psi_ref, free_tilt (4: 1 for a working servo, 0 for a stuck one; the MPC's own
# layout, not the actuators'), and the rest of the set-point trajectory's coordinated-turn attitude: phi_ref,
# psi_rate_ref, psi_d_ref (docs/mpc.md, deviation 7); and the stage's place on the time grid (docs/design/alternatives.md, the long horizon): its length dt
# (s) and rate_held (1: Psi_dot_prev is the previous stage's rate, held over this one, as in the paper's 10 ms
# stages; 0: a long stage, on which the delayed rate is taken in its continuous-time form); the attitude loop's gains
# (autopilot/control/attitude.py, its GAIN_COUNT-vector); the roll and pitch set-point flown at the previous tick and
# the weight (0 or 1) of the move from it (the first stage only); the paper's Table 2 weights (MpcWeights, in the
# order of MpcWeights.table_2_rows) and the roll and pitch bound (rad). The gains, weights and bound are parameters of the
# compiled functions, not constants in them, so that a changed parameter (MC_*, VT_MPC_*) applies at the next solve.
# The solver writes P_SOLVER itself (RtiSolver.stage_parameters); the dynamics take P_STEP (the grid and the gains).
P_V_SP, P_PSI_REF, P_FREE_TILT, P_PHI_REF, P_PSI_RATE_REF, P_PSI_D_REF = slice(0, 3), 3, slice(4, 8), 8, 9, 10
P_GRID, P_GAINS = slice(11, 13), slice(13, 13 + GAIN_COUNT)
P_DT, P_RATE_HELD = P_GRID.start, P_GRID.start + 1
P_STEP = slice(P_GRID.start, P_GAINS.stop)
P_ATTITUDE_SP_PREV, P_MOVE = slice(P_GAINS.stop, P_GAINS.stop + 2), P_GAINS.stop + 2
P_Q_REF = slice(P_MOVE + 1, P_MOVE + 4)
P_Q_FINAL, P_Q_PSI, P_Q_PSI_DOT = (slice(P_Q_REF.start + 3 * k, P_Q_REF.stop + 3 * k) for k in (1, 2, 3))
P_R_THRUST, P_R_ROTOR_LIFT, P_R_TILT_RATE = P_Q_PSI_DOT.stop, P_Q_PSI_DOT.stop + 1, P_Q_PSI_DOT.stop + 2
P_R_PSI_D = slice(P_R_TILT_RATE + 1, P_R_TILT_RATE + 4)
P_WEIGHTS = slice(P_Q_REF.start, P_R_PSI_D.stop)
P_ATTITUDE_BOUND = slice(P_R_PSI_D.stop, P_R_PSI_D.stop + 2)
# The surfaces' deflections (aileron L, aileron R, elevator, rudder, in -1..1) that give each its positive moment.
FULL_DEFLECTION = (1.0, -1.0, 1.0, 1.0)
# sqrt of the rotors' moment bound's weight (moment_bound_residual): of q_moment_bound while a rotor has failed, of
# q_moment_bound_servo while a tilt servo is jammed (the larger of the two with both), else 0.
P_MOMENT_BOUND = P_ATTITUDE_BOUND.stop
# Per rotor, 1 while it can give thrust, 0 once it has failed: a failed rotor has no lifting component to weigh.
P_WORKING_ROTOR = slice(P_MOMENT_BOUND + 1, P_MOMENT_BOUND + 5)
NP = P_WORKING_ROTOR.stop
P_SOLVER = slice(P_GRID.start, NP)
# The stage the paper's weights are given for (Table 2: 25 stages of 10 ms); a stage of length dt weighs dt / this,
# so the cost stays the same integral on any grid. Also the delay of Psi_dot_prev in the continuous-time form.
REFERENCE_STAGE_S = 0.01


@dataclass(frozen=True)
class MpcWeights:
    """Paper Table 2 (docs/mpc.md, the cost), q_ref ... r_psi_d: stage parameters (VT_MPC_*); the others shape the problem
    (a weight of 0 removes its term) and are built in."""

    q_ref: tuple[float, float, float] = (20.0, 10.0, 50.0)
    q_final: tuple[float, float, float] = (20.0, 10.0, 50.0)
    q_psi: tuple[float, float, float] = (10.0, 20.0, 10.0)
    q_psi_dot: tuple[float, float, float] = (3.0, 3.0, 3.0)
    r_thrust: float = 0.0025  # per N^2 (least effort; see r_rotor_lift and the module docstring)
    r_rotor_lift: float = 0.25  # per N^2, on each rotor's lifting component beyond T_ref(V)
    r_tilt_rate: float = 1.0
    r_psi_d: tuple[float, float, float] = (10.0, 20.0, 10.0)
    # The roll and pitch bound |phi|, |theta| <= MpcLimits.attitude as a soft constraint (docs/mpc.md, deviation 6): a
    # penalty q (width softplus((|angle| - bound) / width))^2, q per rad^2, in every stage and at the end. q = 0
    # makes it the paper's hard state bound again.
    q_attitude_bound: float = 1e6
    attitude_bound_width: float = math.radians(3.0)
    # Each working servo's tilt away from the working servos' mean, per rad^2 (docs/design/alternatives.md, the long horizon); 0 leaves the four
    # tilts independent, as the paper does.
    q_tilt_spread: float = 0.0
    # The yaw's error from its reference bounded softly in every stage (not at the end), |psi - psi_ref| <=
    # yaw_bound (rad), q per rad^2, the roll and pitch bound's width (docs/design/alternatives.md, the long horizon); q = 0: no bound, as the paper.
    q_yaw_bound: float = 0.0
    yaw_bound: float = math.radians(15.0)
    # The first stage's roll and pitch set-point away from the one flown at the previous tick, per rad^2 (move
    # suppression, docs/design/alternatives.md, the long horizon); 0: none, as the paper.
    q_attitude_sp_move: float = 0.0
    # Each stage's cost weighed by its length over REFERENCE_STAGE_S (the same integral on any grid), or each stage
    # alike (as the paper's uniform stages are).
    weigh_by_length: bool = True
    # With a rotor or a tilt servo failed, the moment of the planned rotor thrusts bounded softly to what the control
    # surfaces can cancel at the stage's airspeed, less a margin for the attitude loop (moment_bound_residual): q per
    # (N m)^2 with a rotor failed (VT_MPC_Q_MOM), with a servo jammed (VT_MPC_Q_MOM_SRV, off by default: 10000 holds
    # a rotor jammed past horizontal at walking speed, but costs a slow hover with one jammed at 60 deg 16 m of
    # height); 0 or no failure: no bound, as the paper. The softplus width (N m), the surfaces' share.
    q_moment_bound: float = 1000.0
    q_moment_bound_servo: float = 0.0
    moment_bound_width: float = 0.5
    moment_bound_share: float = 0.5
    # The factor on the north and east velocity weights (q_ref, q_final) while a rotor has failed (VT_MPC_QV_FAIL):
    # at the paper's weights the plan then flew 1-1.6 m/s over the set-point at 18 m/s, buying wing lift and rotor
    # effort with speed (docs/mpc.md, the solver); 1: the paper's weights.
    q_velocity_rotor_failed: float = 6.0

    def table_2_rows(self) -> np.ndarray:
        """The Table 2 weights as the stage parameters P_WEIGHTS carry them."""
        return np.array((*self.q_ref, *self.q_final, *self.q_psi, *self.q_psi_dot, self.r_thrust, self.r_rotor_lift,
                         self.r_tilt_rate, *self.r_psi_d), dtype=float)  # fmt: skip

    def built_in(self) -> MpcWeights:
        """These weights with the Table 2 ones at their defaults: what a built problem depends on."""
        return replace(self, q_ref=MpcWeights.q_ref, q_final=MpcWeights.q_final, q_psi=MpcWeights.q_psi,
                       q_psi_dot=MpcWeights.q_psi_dot, r_thrust=MpcWeights.r_thrust,
                       r_rotor_lift=MpcWeights.r_rotor_lift, r_tilt_rate=MpcWeights.r_tilt_rate,
                       r_psi_d=MpcWeights.r_psi_d, q_moment_bound=MpcWeights.q_moment_bound,
                       q_moment_bound_servo=MpcWeights.q_moment_bound_servo,
                       q_velocity_rotor_failed=MpcWeights.q_velocity_rotor_failed)  # fmt: skip


@dataclass(frozen=True)
class SoftTiltCost:
    """J_soft = exp(a v_B chi + b chi + c v_B + d), chi = mean tilt in degrees, v_B forward body speed (m/s).

    The authors' final constants (docs/mpc.md, the cost); the paper's stated ones contradict its own table. The exponent is
    capped so the solver stays well conditioned.
    """

    a: float = -0.332
    b: float = 1.8
    c: float = -0.477
    d: float = -2.303
    exponent_cap: float = 30.0

    def exponent(self, forward_speed: ca.SX, mean_tilt_deg: ca.SX) -> ca.SX:
        s = self.a * forward_speed * mean_tilt_deg + self.b * mean_tilt_deg + self.c * forward_speed + self.d
        return ca.fmin(s, self.exponent_cap)

    def cost(self, forward_speed: ca.SX, mean_tilt_deg: ca.SX) -> ca.SX:
        return ca.exp(self.exponent(forward_speed, mean_tilt_deg))


@dataclass(frozen=True)
class MpcLimits:
    """Constraints (paper eq. for the constraints; docs/mpc.md, constraints)."""

    attitude: tuple[float, float] = (math.pi / 4, math.pi / 4)  # |phi|, |theta|
    attitude_sp: tuple[float, float] = (math.pi / 3, math.pi / 3)  # |phi_d|, |theta_d|
    yaw_sp_offset: float = math.pi / 2  # |psi_d - psi|
    rate: float = math.pi  # |Psi_dot|
    velocity: tuple[float, float, float] = (30.0, 30.0, 10.0)
    tilt_rate: float = math.pi / 4  # rad/s
    # The thrust bound per rotor (the paper's 23 N) is the airframe's thrust_planned_max; the tilt range its own.


def continuous_dynamics(airframe: Airframe, gains: ca.SX, x: ca.SX, u: ca.SX, rate_held: ca.SX = 1) -> ca.SX:
    """d/dt of (v, chi, Psi, Psi_dot) with the attitude loop's `gains` (AttitudeGains.vector, symbols or numbers).
    rate_held 1: Psi_dot_prev is held over the interval (the paper's 10 ms stages); 0: the delayed rate in continuous
    time, Psi_dot_prev = Psi_dot(t - tau) ~ Psi_dot - tau Psi_ddot with tau = REFERENCE_STAGE_S, so that
    K_d (Psi_dot_prev - Psi_dot) = -K_d tau Psi_ddot: on a stage many ticks long a held rate would be that many ticks
    old (docs/design/alternatives.md, the long horizon)."""
    euler = x[PSI]
    rotation = rotation_from_euler(euler)
    v_air_body = rotation.T @ x[V]
    force, _ = body_wrench(airframe, u[THRUST], x[CHI], ca.SX.zeros(4), v_air_body, ca.SX.zeros(3))
    v_dot = rotation @ force / airframe.mass + ca.vertcat(0, 0, airframe.gravity)
    held = attitude_law(euler, x[PSI_DOT], x[PSI_DOT_PREV], u[PSI_D], gains)
    k_d = gains[RATE_D_GAINS]
    continuous = (held - k_d * (x[PSI_DOT_PREV] - x[PSI_DOT])) / (1 + k_d * REFERENCE_STAGE_S)
    psi_ddot = rate_held * held + (1 - rate_held) * continuous
    return ca.vertcat(v_dot, u[CHI_DOT], x[PSI_DOT], psi_ddot)


def discrete_dynamics(airframe: Airframe, substeps: int = 1) -> ca.Function:
    """F(x, u, step) -> x_next: `substeps` RK4 steps over the stage, step = (dt, rate_held, the attitude gains) (the
    stage parameters P_STEP, step_parameters); Psi_dot_prev(k+1) = Psi_dot(k)."""
    x = ca.SX.sym("x", NX)
    u = ca.SX.sym("u", NU)
    step = ca.SX.sym("step", P_STEP.stop - P_STEP.start)
    rate_held, gains = step[1], step[2:]
    dt = step[0] if substeps == 1 else step[0] / substeps

    def f(z: ca.SX) -> ca.SX:
        return continuous_dynamics(airframe, gains, ca.vertcat(z, x[PSI_DOT_PREV]), u, rate_held)

    z = x[0:13]
    for _ in range(substeps):
        k1 = f(z)
        k2 = f(z + dt / 2 * k1)
        k3 = f(z + dt / 2 * k2)
        k4 = f(z + dt * k3)
        z = z + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return ca.Function("mpc_step", [x, u, step], [ca.vertcat(z, x[PSI_DOT])], ["x", "u", "step"], ["x_next"])


def step_parameters(dt: float, rate_held: bool, gains: np.ndarray) -> np.ndarray:
    """The dynamics' stage parameters P_STEP: a stage of `dt` seconds with the attitude gains (GAIN_COUNT)."""
    return np.concatenate(((dt, 1.0 if rate_held else 0.0), gains))


def soft_bound(q: float, width: float, excess: ca.SX) -> ca.SX:
    """~0 where excess (how far beyond the bound) < -a few widths, ~sqrt(q) excess beyond it; smooth (softplus),
    so that the Gauss-Newton Hessian sees the bound before the plan reaches it."""
    return math.sqrt(q) * width * softplus(excess / width)


def softplus(scaled: ca.SX) -> ca.SX:
    """log(1 + e^scaled), taken as scaled itself beyond 30 (where they agree to double precision)."""
    return ca.if_else(scaled > 30, scaled, ca.log1p(ca.exp(ca.fmin(scaled, 30))))


def attitude_bound_residual(weights: MpcWeights, x: ca.SX, bound: ca.SX) -> ca.SX:
    """The soft roll and pitch bound |angle| <= bound (rad, the stage parameters P_ATTITUDE_BOUND; docs/mpc.md,
    deviation 6)."""
    if weights.q_attitude_bound <= 0:
        return ca.SX.zeros(0)
    angles = x[ROLL_PITCH]
    return soft_bound(weights.q_attitude_bound, weights.attitude_bound_width,
                      ca.vertcat(angles - bound, -angles - bound))  # fmt: skip


def moment_bound_residual(airframe: Airframe, weights: MpcWeights, x: ca.SX, u: ca.SX, sqrt_q: ca.SX) -> ca.SX:
    """The soft bound |M_i| <= share x the surfaces' reach in roll and pitch, M the moment of the planned rotor
    thrusts at the planned tilts, weighed q per (N m)^2 (sqrt_q: the stage parameter P_MOMENT_BOUND). The MPC plans
    the rotors for force; with a rotor out, thrust the remaining three share equally makes a moment that only the
    surfaces can cancel, and where they cannot the allocator leaves it (the rotor-failure map lost the aircraft so at
    18 m/s, docs/campaigns.md). The surfaces' reach is their full deflection at the stage's airspeed
    (aircraft.aerodynamics). Yaw is left to the allocator's differential thrust: the rudder cancels a tenth of what
    the ailerons and the elevator do, and a yaw bound that tight made the plans at cruise worse, not safer."""
    v_air_body = rotation_from_euler(x[PSI]).T @ x[V]
    _, moment = rotor_wrench(airframe, u[THRUST], x[CHI])
    reach = weights.moment_bound_share * ca.fabs(surface_moment(airframe, v_air_body, ca.DM(FULL_DEFLECTION)))
    width = weights.moment_bound_width
    return sqrt_q * width * softplus(ca.vertcat(moment[0:2] - reach[0:2], -moment[0:2] - reach[0:2]) / width)


def yaw_bound_residual(weights: MpcWeights, x: ca.SX, psi_ref: ca.SX) -> ca.SX:
    """The soft bound |psi - psi_ref| <= yaw_bound: on a 2 s horizon the cheapest braking at speed was to yaw the
    aircraft across its course and brake on the fuselage's side force (docs/design/alternatives.md, the long horizon)."""
    if weights.q_yaw_bound <= 0:
        return ca.SX.zeros(0)
    error = wrap_angle(x[PSI_INDEX] - psi_ref)
    return soft_bound(weights.q_yaw_bound, weights.attitude_bound_width,
                      ca.vertcat(error - weights.yaw_bound, -error - weights.yaw_bound))  # fmt: skip


def tilt_spread_residual(weights: MpcWeights, x: ca.SX, free_tilt: ca.SX) -> ca.SX:
    """sqrt(q) (chi_i - mean chi) for each working servo: the model plans force alone, and a tilt split between the
    left and right rotors is a yaw moment it does not see (on a long horizon its plans split them and spun the
    aircraft up, docs/design/alternatives.md, the long horizon). A stuck servo is not counted."""
    if weights.q_tilt_spread <= 0:
        return ca.SX.zeros(0)
    mean = ca.dot(free_tilt, x[CHI]) / ca.fmax(ca.sum1(free_tilt), 1)
    return math.sqrt(weights.q_tilt_spread) * free_tilt * (x[CHI] - mean)


def attitude_sp_move_residual(weights: MpcWeights, u: ca.SX, p: ca.SX) -> ca.SX:
    """sqrt(q) (roll and pitch set-point - the previous tick's), where the stage's P_MOVE is 1 (the first)."""
    if weights.q_attitude_sp_move <= 0:
        return ca.SX.zeros(0)
    return p[P_MOVE] * math.sqrt(weights.q_attitude_sp_move) * (u[ROLL_PITCH_D] - p[P_ATTITUDE_SP_PREV])


def stage_residual(airframe: Airframe, weights: MpcWeights, soft: SoftTiltCost, x: ca.SX, u: ca.SX, p: ca.SX) -> ca.SX:
    """Residual r with |r|^2 = the stage cost (Gauss-Newton form), weighted by the stage's length over
    REFERENCE_STAGE_S; the Table 2 weights are the stage's parameters, the other terms `weights`'."""
    v_sp, psi_ref, free_tilt = p[P_V_SP], p[P_PSI_REF], p[P_FREE_TILT]
    phi_ref, psi_rate_ref, psi_d_ref = p[P_PHI_REF], p[P_PSI_RATE_REF], p[P_PSI_D_REF]
    euler = x[PSI]
    forward_speed = (rotation_from_euler(euler).T @ x[V])[0]
    # Mean over the servos that work: a stuck servo's tilt is not the controller's to choose, and counting it
    # would pin the cost at its cap (e.g. a servo stuck at 60 deg in a hover) and ruin the QP's conditioning.
    mean_tilt_deg = ca.dot(free_tilt, x[CHI]) / ca.fmax(ca.sum1(free_tilt), 1) * (180 / math.pi)
    # Thrust is weighed beyond the share of the weight the wing cannot carry at this stage's airspeed (see the
    # module docstring): T_ref = m g / 4 (1 - e(V)), no mode switch, from the shared model's e(V).
    airspeed = ca.sqrt(ca.sumsqr(x[V]) + 1e-6)
    thrust_ref = airframe.mass * airframe.gravity / 4 * (1 - aero_effectiveness(airframe, airspeed))
    sq = ca.sqrt
    scale = sq(p[P_DT] / REFERENCE_STAGE_S) if weights.weigh_by_length else 1
    return scale * ca.vertcat(
        sq(p[P_Q_REF]) * (x[V] - v_sp),
        sq(p[P_Q_PSI]) * ca.vertcat(euler[0] - phi_ref, euler[1], wrap_angle(euler[2] - psi_ref)),
        sq(p[P_Q_PSI_DOT]) * (x[PSI_DOT] - ca.vertcat(0, 0, psi_rate_ref)),
        sq(p[P_R_TILT_RATE]) * u[CHI_DOT],
        sq(p[P_R_THRUST]) * u[THRUST],
        sq(p[P_R_ROTOR_LIFT]) * p[P_WORKING_ROTOR] * (u[THRUST] * ca.cos(x[CHI]) - thrust_ref),
        sq(p[P_R_PSI_D]) * ca.vertcat(u[PSI_D][0] - phi_ref, u[PSI_D][1], wrap_angle(u[PSI_D][2] - psi_d_ref)),
        ca.exp(soft.exponent(forward_speed, mean_tilt_deg) / 2),
        attitude_bound_residual(weights, x, p[P_ATTITUDE_BOUND]),
        yaw_bound_residual(weights, x, psi_ref),
        tilt_spread_residual(weights, x, free_tilt),
        attitude_sp_move_residual(weights, u, p),
        moment_bound_residual(airframe, weights, x, u, p[P_MOMENT_BOUND]),
    )


def terminal_residual(weights: MpcWeights, x: ca.SX, p: ca.SX) -> ca.SX:
    return ca.vertcat(
        ca.sqrt(p[P_Q_FINAL]) * (x[V] - p[P_V_SP]), attitude_bound_residual(weights, x, p[P_ATTITUDE_BOUND])
    )


def angle_chain(start: float, angles: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """psi_k = psi_{k-1} + wrap(angle_k - psi_{k-1}) where valid_k, else psi_{k-1}, from psi_{-1} = start: each
    stage's angle unwrapped to within pi of the stage before, so that the plan never turns the long way round."""
    unwrapped = np.concatenate(([start], angles[valid]))
    steps = unwrapped[1:] - unwrapped[:-1]
    chain = start + np.concatenate(([0.0], np.arctan2(np.sin(steps), np.cos(steps)).cumsum()))
    return chain[valid.cumsum()]


def yaw_references(v_sp: np.ndarray, yaw_now: float) -> np.ndarray:
    """psi_ref at each stage of the set-point v_sp (3, T): its course where it has one
    (autopilot.control.velocity_command.setpoint_course), else the stage before's, the current yaw before the first
    (docs/mpc.md, the yaw reference)."""
    return angle_chain(yaw_now, np.arctan2(v_sp[1], v_sp[0]), has_course(v_sp[0], v_sp[1]))
