"""The MPC's horizon grids on the braking of accel-decel, in one process (plant physics + flight controller).

    python benchmarks/bench_horizon.py [--grids paper,long] [--profile accel-decel] [--seconds 32] [--decel A]

A screening tool for the grids of docs/design/alternatives.md, the long horizon (the decision itself rests on `vtol scenario` through MAVLink).
Per grid: the largest velocity error |v - v_sp| while braking (15-28 s of accel-decel; sideways too), max |v_z|,
max |pitch|, max |roll|, the largest heading error from the set-point's course, the largest tick-to-tick step of
the pitch set-point, failed solves, whether the PID took over, and the solve times.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from collections.abc import Callable, Iterator

import numpy as np
from bench_mpc import spread, vehicle_state

from aircraft.airframe import load_airframe
from autopilot.control.flight_controller import FlightController
from autopilot.controllers import MPC, build_flight_controller
from autopilot.mpc.horizon import HORIZONS, LONG, MpcHorizon, StageGrid
from autopilot.topics.vehicle_state import VehicleState
from ground_tools.metrics import heading_error_max_deg
from scenarios.profiles import DECEL_CRUISE, DECEL_START_S, PROFILES, accel_decel_braking_at
from sim_bridge.plant import Plant, Spawn

BRAKING_S = (DECEL_START_S, 28.0)  # accel-decel's braking from 24 m/s at 2 m/s^2, and 1 s after it


def velocity_ticks(
    horizon: MpcHorizon, profile: Callable[[float], np.ndarray], seconds: float
) -> Iterator[tuple[VehicleState, FlightController, np.ndarray]]:
    """Fly the profile in one process (plant physics + flight controller, no sockets) from a hover at 100 m: at each
    velocity tick, after the set-point is given and before the controller runs, the state, the controller and the
    set-point."""
    airframe = load_airframe()
    plant = Plant(airframe, Spawn(altitude=100.0))
    controller = build_flight_controller(airframe, MPC, mpc_horizon=horizon)
    state = VehicleState()
    for _ in range(int(seconds * 400)):
        vehicle_state(plant, state)
        if controller.velocity_due(state.time_usec):
            v_sp = profile(state.time_s)
            controller.set_velocity_setpoint(v_sp)
            yield state, controller, v_sp
        controller.step(state)
        plant.set_command(controller.command)
        plant.step()


def fly(
    horizon: MpcHorizon,
    profile: Callable[[float], np.ndarray],
    seconds: float,
    braking_s: tuple[float, float] = BRAKING_S,
) -> dict:
    rows, solve_ms = [], []
    for state, controller, v_sp in velocity_ticks(horizon, profile, seconds):
        if controller.mpc is not None and controller.mpc.solve_times.count > len(solve_ms):
            solve_ms.append(controller.mpc.solve_times.last_s * 1e3)
        rows.append((state.time_s, *state.velocity_ned, *v_sp, *np.degrees(state.euler),
                     np.degrees(controller.velocity_command.euler_sp[1])))  # fmt: skip
    t, vx, vy, vz, sx, sy, sz, roll, pitch, yaw, pitch_sp = np.array(rows).T
    braking = (t >= braking_s[0]) & (t <= braking_s[1])
    error = np.sqrt((vx - sx) ** 2 + (vy - sy) ** 2 + (vz - sz) ** 2)  # the whole vector's: a skid's v_y counts
    mpc = controller.mpc
    return {
        "braking_error_max": float(error[braking].max()) if braking.any() else float("nan"),
        "vx_rmse": float(np.sqrt(np.mean((vx - sx) ** 2))),
        "vz_max": float(np.abs(vz).max()),
        "pitch_max": float(np.abs(pitch).max()),
        "roll_max": float(np.abs(roll).max()),
        "yaw_error_max": heading_error_max_deg(np.radians(yaw), sx, sy),  # deg off the set-point's course; None
        "pitch_sp_step_max": float(np.abs(np.diff(pitch_sp)).max()),
        "braking_pitch_sp_step_max": float(np.abs(np.diff(pitch_sp))[braking[1:]].max()) if braking.any() else 0.0,
        "failed": mpc.solves_failed if mpc else -1,
        "fell_back": controller.fell_back_to_pid,
        "ms": solve_ms,
    }


def parse_horizon(text: str) -> MpcHorizon:
    """A horizon by name (paper, long) or a grid as COUNTxTICKS+..., e.g. 10x1+15x13 (10 one-tick stages, 15 of 13
    ticks), with the long horizon's weights and one Gauss-Newton step per tick; options after it: /sM (M RK4 steps
    per stage), /qQ (q_tilt_spread), /mQ (q_attitude_sp_move), /u (stages weighed alike), /yQ (q_yaw_bound),
    /YD (yaw_bound, deg), /LR (r_rotor_lift), /iK (K Gauss-Newton steps per tick)."""
    text, *options = text.split("/")
    if text in HORIZONS:
        horizon = HORIZONS[text]
    else:
        ticks: list[int] = []
        for part in text.split("+"):
            count, length = part.split("x")
            ticks += [int(length)] * int(count)
        horizon = MpcHorizon(text, StageGrid(tuple(ticks)), LONG.weights)
    grid, weights, steps = horizon.grid, horizon.weights, horizon.gauss_newton_steps
    for option in options:
        if option.startswith("s"):
            grid = grid.but(substeps=int(option[1:]))
        elif option.startswith("q"):
            weights = dataclasses.replace(weights, q_tilt_spread=float(option[1:]))
        elif option.startswith("y"):
            weights = dataclasses.replace(weights, q_yaw_bound=float(option[1:]))
        elif option.startswith("Y"):
            weights = dataclasses.replace(weights, yaw_bound=math.radians(float(option[1:])))
        elif option.startswith("L"):
            weights = dataclasses.replace(weights, r_rotor_lift=float(option[1:]))
        elif option.startswith("i"):
            steps = int(option[1:])
        elif option == "u":
            weights = dataclasses.replace(weights, weigh_by_length=False)
        elif option.startswith("m"):
            weights = dataclasses.replace(weights, q_attitude_sp_move=float(option[1:]))
    return MpcHorizon(horizon.name, grid, weights, steps)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grids", default="paper,long")
    parser.add_argument("--profile", default="accel-decel", choices=sorted(PROFILES))
    parser.add_argument("--seconds", type=float, help="default: the profile's length (accel-decel 32 s)")
    parser.add_argument(
        "--decel",
        type=float,
        metavar="A",
        help="accel-decel braking at A m/s^2 instead of 2 (the braking window and length follow)",
    )
    args = parser.parse_args()
    profile, seconds = PROFILES[args.profile]
    braking_s = BRAKING_S
    if args.decel is not None:
        if args.profile != "accel-decel" or args.decel <= 0:
            parser.error("--decel needs --profile accel-decel and a positive deceleration")
        profile, stop_s = accel_decel_braking_at(args.decel), DECEL_START_S + DECEL_CRUISE / args.decel
        braking_s, seconds = (BRAKING_S[0], stop_s + 1.0), stop_s + 5.0
    seconds = args.seconds or seconds
    for name in args.grids.split(","):
        horizon = parse_horizon(name)
        grid = horizon.grid
        r = fly(horizon, profile, seconds, braking_s)
        print(f"{name:12s} span {grid.span_s:5.2f} s  braking |v err| max {r['braking_error_max']:5.2f} m/s  "
              f"vx RMS {r['vx_rmse']:5.2f}  |vz| max {r['vz_max']:5.2f}  |pitch| max {r['pitch_max']:5.1f} deg  "
              f"|roll| max {r['roll_max']:5.1f} deg  |yaw - course| max {r['yaw_error_max'] or 0.0:5.1f} deg  "
              f"pitch sp step max {r['pitch_sp_step_max']:5.1f} (braking {r['braking_pitch_sp_step_max']:5.1f}) deg  "
              f"failed {r['failed']}  PID {r['fell_back']}  "
              f"{spread(r['ms']) if r['ms'] else ''}", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
