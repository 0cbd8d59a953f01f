"""How well the MPC's own model can brake: a braking manoeuvre for accel-decel found by IPOPT, against the goal.

    python benchmarks/bench_braking_bound.py [--horizon paper|long] [--seconds 4] [--stage 0.1] [--on-course]
                                             [--guess TILT_DEG,THRUST_N,PITCH_DEG] [--decel A]

Issue 13 asks of the MPC a velocity error of at most 1.5 m/s while accel-decel brakes from 24 m/s at 2 m/s^2, with
|v_z| <= 0.5 m/s and |pitch| <= 25 deg. Is that the vehicle's limit or the controller's? This flies the profile in
one process with the chosen horizon up to the start of the braking (15 s) and takes the MPC's state there (velocity,
tilts, attitude, rates). From that state IPOPT then looks for inputs of the MPC's model (the same dynamics function,
tilt-rate, thrust and attitude set-point bounds) that keep the largest |v - v_sp| over the first `--seconds` of the
ramp smallest, with |v_z| and |pitch| held to the goals (with --on-course |v_y| too, as |v_z|): a controller told of
the ramp when it starts, flying the model exactly (no servo or motor lag, an allocator that always delivers). The
error is the whole vector's, v_sp = (ramp, 0, 0): a braking that slides sideways (a bank or a yaw into a sideslip)
pays for its v_y, as a flight's velocity error does. The problem is not convex, so what IPOPT returns is a local
optimum: a braking the model can fly (the best one is at least as good), not a bound below which
no controller can go. docs/design/alternatives.md, the long horizon gives what it measured.
"""

from __future__ import annotations

import argparse
import math
import time

import casadi as ca
import numpy as np
from bench_horizon import BRAKING_S, velocity_ticks

from aircraft.airframe import load_airframe
from autopilot.control.attitude import DEFAULT_GAINS
from autopilot.mpc.horizon import HORIZONS
from autopilot.mpc.model import CHI, CHI_DOT, NU, NX, PSI, PSI_D, THRUST, MpcLimits, discrete_dynamics, step_parameters
from scenarios.profiles import PROFILES, accel_decel_braking_at

GOALS = {"braking error": 1.5, "|v_z|": 0.5, "|pitch|": 25.0}  # m/s, m/s, deg
PITCH = PSI.start + 1
SUBSTEP_S = 0.01  # RK4 steps of the MPC's own 10 ms inside each stage


def cruise_state(horizon: str) -> np.ndarray:
    """The MPC's state x_0 at its last tick before the braking starts (read once that tick has run)."""
    controller = None
    for _, controller, _ in velocity_ticks(HORIZONS[horizon], PROFILES["accel-decel"][0], BRAKING_S[0]):  # noqa: B007 (the last one is kept)
        pass
    if controller is None or controller.mpc is None:
        raise SystemExit("the MPC did not fly up to the braking")
    return controller.mpc.last_x0.copy()


def best_braking(
    x0: np.ndarray,
    seconds: float,
    stage_s: float,
    on_course: bool = False,
    guess: tuple[float, float, float] = (70.0, 5.0, 0.0),
    deceleration: float = 2.0,
) -> dict:
    """A local minimum over the model's inputs of max_k |v_k - v_sp,k|, v_sp = (the ramp from t = 0, 0, 0), with
    |v_z| and |pitch| bounded (on_course: |v_y| too). guess: IPOPT's start, the tilts (deg), thrusts (N) and pitch
    (deg) all along. Raises RuntimeError (with IPOPT's status) when IPOPT does not converge."""
    airframe, limits = load_airframe(), MpcLimits()
    stages = int(round(seconds / stage_s))
    step = discrete_dynamics(airframe, substeps=max(1, int(round(stage_s / SUBSTEP_S))))
    opti = ca.Opti()
    x, u, worst = opti.variable(NX, stages + 1), opti.variable(NU, stages), opti.variable()
    profile = accel_decel_braking_at(deceleration)
    ramp = np.array([profile(BRAKING_S[0] + k * stage_s)[0] for k in range(stages + 1)])
    # the delayed rate in continuous time, as on the long horizon's stages
    grid = ca.DM(step_parameters(stage_s, False, DEFAULT_GAINS.vector()))
    opti.subject_to(x[:, 0] == x0)
    for k in range(stages):
        opti.subject_to(x[:, k + 1] == step(x[:, k], u[:, k], grid))
        opti.subject_to(opti.bounded(-limits.tilt_rate, u[CHI_DOT, k], limits.tilt_rate))
        opti.subject_to(opti.bounded(0.0, u[THRUST, k], airframe.thrust_planned_max))
        opti.subject_to(opti.bounded(-ca.DM(limits.attitude_sp), u[PSI_D, k][0:2], ca.DM(limits.attitude_sp)))
        opti.subject_to(u[PSI_D, k][2] == x0[PSI.stop - 1])  # the heading held (nothing else weighs the yaw)
    goal_pitch = math.radians(GOALS["|pitch|"])
    opti.subject_to(worst >= 0)
    for k in range(1, stages + 1):
        opti.subject_to(ca.sumsqr(x[0:3, k] - ca.vertcat(ramp[k], 0, 0)) <= worst**2)
        opti.subject_to(opti.bounded(-GOALS["|v_z|"], x[2, k], GOALS["|v_z|"]))
        if on_course:
            opti.subject_to(opti.bounded(-GOALS["|v_z|"], x[1, k], GOALS["|v_z|"]))
        opti.subject_to(opti.bounded(-goal_pitch, x[PITCH, k], goal_pitch))
        opti.subject_to(opti.bounded(airframe.tilt_min, x[CHI, k], airframe.tilt_max))
    opti.minimize(worst + 1e-4 * ca.sumsqr(u[CHI_DOT, :]) + 1e-6 * ca.sumsqr(u[THRUST, :]))
    opti.set_initial(x[0, :], ramp)
    tilt_deg, thrust, pitch_deg = guess
    opti.set_initial(x[CHI, :], math.radians(tilt_deg))
    opti.set_initial(u[THRUST, :], thrust)
    opti.set_initial(x[PITCH, :], math.radians(pitch_deg))
    opti.set_initial(u[PSI_D.start + 1, :], math.radians(pitch_deg))
    opti.set_initial(worst, 2.0)
    opti.solver("ipopt", {"print_time": False, "expand": True}, {"print_level": 0, "max_iter": 3000, "tol": 1e-6})
    started = time.perf_counter()
    solution = opti.solve()
    states = solution.value(x)
    errors = np.linalg.norm(states[0:3] - np.vstack((ramp, np.zeros((2, stages + 1)))), axis=0)
    return {
        "worst": float(solution.value(worst)),
        "at_s": float(np.argmax(errors) * stage_s),
        "pitch_deg": float(np.degrees(np.abs(states[PITCH]).max())),
        "roll_deg": float(np.degrees(np.abs(states[PSI.start]).max())),
        "vz": float(np.abs(states[2]).max()),
        "vy": float(np.abs(states[1]).max()),
        "tilts_deg": np.degrees(states[CHI][:, [0, -1]]),
        "solve_s": time.perf_counter() - started,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--horizon", choices=sorted(HORIZONS), default="paper", help="which MPC flies to the braking")
    parser.add_argument("--seconds", type=float, default=4.0, help="the window of the ramp bounded (s)")
    parser.add_argument("--stage", type=float, default=0.1, help="stage length of the bound's problem (s)")
    parser.add_argument("--on-course", action="store_true", help="bound |v_y| as |v_z|: no sliding sideways")
    parser.add_argument("--guess", default="70,5,0", help="IPOPT's start: tilt (deg), thrust (N), pitch (deg)")
    parser.add_argument("--decel", type=float, default=2.0, help="the braking's deceleration (m/s^2; accel-decel: 2)")
    args = parser.parse_args()
    x0 = cruise_state(args.horizon)
    print(
        f"cruise at {BRAKING_S[0]:g} s ({args.horizon} horizon): v_x {x0[0]:.2f} m/s, tilts "
        f"{np.round(np.degrees(x0[CHI]), 1).tolist()} deg, pitch {math.degrees(x0[PITCH]):.2f} deg"
    )
    tilt_deg, thrust, pitch_deg = (float(text) for text in args.guess.split(","))
    best = best_braking(x0, args.seconds, args.stage, args.on_course, (tilt_deg, thrust, pitch_deg), args.decel)
    print(
        f"best braking over the first {args.seconds:g} s of the ramp (stages of {args.stage:g} s, IPOPT "
        f"{best['solve_s']:.0f} s): largest |v - v_sp| {best['worst']:.3f} m/s at {best['at_s']:.2f} s "
        f"(goal <= {GOALS['braking error']:g}), |pitch| up to {best['pitch_deg']:.1f} deg, |roll| up to "
        f"{best['roll_deg']:.1f} deg, |v_z| up to {best['vz']:.2f} m/s, |v_y| up to {best['vy']:.2f} m/s; tilts "
        f"{np.round(best['tilts_deg'][:, 0], 0).tolist()} -> "
        f"{np.round(best['tilts_deg'][:, 1], 0).tolist()} deg"
    )


if __name__ == "__main__":
    main()
