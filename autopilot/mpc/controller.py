"""The unified velocity MPC as the autopilot's velocity controller (VT_CTRL = 1, `--controller mpc`).

Each 100 Hz tick: the state x0 from the vehicle (velocity, the servo estimate's tilts, Euler angles and
rates, the previous tick's rates), the failure-aware bounds from what the allocator and the servo estimate
know, one RTI solve, and the first stage of the plan handed on: the attitude set-point to the attitude
loop, the tilts to the servos, the planned body force (rotors + wing) to the allocator. No mode logic.

A failed solve flies on the shifted previous plan; after MAX_FAILURES in a row the controller asks the
flight controller to fall back to the PID baseline (paper), which it reports.
"""

from __future__ import annotations

import math

import numpy as np

from aircraft.actuators import ALLOCATED_ROTORS
from aircraft.airframe import Airframe
from aircraft.codegen import BufferedFunction
from aircraft.frames import wrap
from autopilot.control.actuator_health import ServoEstimate
from autopilot.control.allocation import ControlAllocator
from autopilot.control.attitude import AttitudeGains, euler_rates
from autopilot.control.tuning import attitude_gains
from autopilot.control.velocity_command import SetpointTrajectory, VelocityCommand, course_rates, has_course
from autopilot.mpc.horizon import PAPER, MpcHorizon, extrapolate_setpoint
from autopilot.mpc.model import (
    CHI,
    NP,
    NX,
    P_FREE_TILT,
    P_PHI_REF,
    P_PSI_D_REF,
    P_PSI_RATE_REF,
    P_PSI_REF,
    P_V_SP,
    PSI_D,
    PSI_INDEX,
    THRUST,
    MpcLimits,
    MpcWeights,
    V,
    angle_chain,
    yaw_references,
)
from autopilot.mpc.rti import MpcSolution, RtiSolver, planned_force_function
from autopilot.mpc.solve_times import SolveTimes
from autopilot.mpc.tuning import mpc_limits, mpc_weights
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawReference

DEFAULT_HORIZON = PAPER  # the stages' lengths and their weights (docs/design/alternatives.md, the long horizon)
MAX_FAILURES = 3
LEVENBERG = 0.1  # Marquardt damping of each RTI step (mpc.py)
WARM_UP_ITERATIONS = 10  # RTI iterations at the first state, so the first plan is converged


def coordinated_roll(acceleration_ned: np.ndarray, heading: np.ndarray, gravity: float, limit: float) -> np.ndarray:
    """The bank (rad) of a coordinated turn making the set-point's horizontal acceleration across the heading:
    atan(a_lateral / g), at each column of acceleration_ned (3, T) and heading (T,) (or one of each). The rotors
    tilt only in the body x-z plane, so lateral force comes from banking (or from sideslip, which a coordinated
    turn avoids)."""
    lateral = -acceleration_ned[0] * np.sin(heading) + acceleration_ned[1] * np.cos(heading)
    return np.minimum(np.maximum(np.arctan2(lateral, gravity), -limit), limit)  # np.clip's result, less overhead


def held_yaw(hold: float | None, yaw: float, on_course: bool) -> float:
    """The heading the MPC holds at low speed (docs/mpc.md, the yaw reference): the yaw of the last tick the set-point
    had a course (or a yaw reference), kept while it has none; while it has one, the current yaw (rad)."""
    return yaw if on_course or hold is None else hold


class MpcVelocityController:
    """Velocity set-point -> VelocityCommand through the unified MPC."""

    def __init__(
        self,
        airframe: Airframe,
        allocator: ControlAllocator,
        servos: ServoEstimate,
        horizon: MpcHorizon = DEFAULT_HORIZON,
        limits: MpcLimits = MpcLimits(),
    ) -> None:
        self.airframe = airframe
        self.allocator = allocator
        self.servos = servos
        self.limits = limits
        self.horizon = horizon
        grid = horizon.grid
        self.solver = RtiSolver(
            airframe, grid, limits, weights=horizon.weights, gauss_newton_steps=horizon.gauss_newton_steps
        )
        self.solver.levenberg = LEVENBERG
        self.force_function = BufferedFunction(planned_force_function(airframe))
        self.params = np.zeros((NP, grid.stages + 1))
        self._health = b""  # the failure knowledge the bounds were last worked out from (_bounds_from_health)
        self.previous_rates: np.ndarray | None = None
        self.mode_switches = 0  # the MPC has no modes (VelocityController's counter)
        self.failures_in_row = 0
        self.solves_failed = 0
        self.solve_times = SolveTimes()
        self.fallback_requested = False
        self.last_solution: MpcSolution | None = None
        self.last_x0 = np.zeros(NX)
        self.yaw_hold: float | None = None  # the heading held while the set-point has no course (held_yaw)
        self.trajectory = SetpointTrajectory()
        # The servos lag by their time constant (30 ms): command the plan's tilt that far (3 stages) ahead.
        self.tilt_lead_stages = grid.node_at(airframe.servo_tau)

    def health_changed(self, allocator: ControlAllocator, servos: ServoEstimate) -> None:
        """A failure became known. Nothing to copy: this controller shares the allocator and the servo estimate and
        reads its bounds from them at every tick."""

    def set_tuning(self, gains: AttitudeGains, weights: MpcWeights, limits: MpcLimits) -> None:
        """The attitude loop's gains (its model of the loop), the Table 2 weights and the limits from the next solve."""
        self.solver.set_tuning(gains, weights, limits)
        self.limits = limits

    def retune(self, params: ParameterStore) -> None:
        """The parameters' gains, weights and limits (MC_*, VT_MPC_*) from the next solve on."""
        self.set_tuning(
            attitude_gains(params), mpc_weights(params, self.horizon.weights), mpc_limits(params, self.limits)
        )

    def predict_tick(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The model's state one controller tick after x under the input u."""
        return self.solver.predict_tick(x, u)

    def _bounds_from_health(self) -> None:
        """What the allocator and the servo estimate know of failures, as the MPC's bounds (docs/mpc.md, the solver,
        failures); read at every tick, worked out again only when it changed."""
        a, allocator, servos = self.airframe, self.allocator, self.servos
        health = b"".join(values.tobytes() for values in (allocator.effectiveness, allocator.lower, allocator.upper,
                                                          servos.stuck, servos.rate_scale))  # fmt: skip
        if health == self._health:
            return
        self._health = health
        working = allocator.effectiveness[ALLOCATED_ROTORS] > 0
        planned_max = np.minimum(a.thrust_planned_max, allocator.upper[ALLOCATED_ROTORS] * a.thrust_max)
        thrust_max = np.where(working, planned_max, 0.0)
        thrust_min = np.where(working, allocator.lower[ALLOCATED_ROTORS] * a.thrust_max, 0.0)
        self.solver.set_actuator_limits(thrust_max, self.servos.stuck, thrust_min, self.servos.rate_scale)

    def _set_parameters(self, v_sp: np.ndarray, yaw: float, time_usec: int, reference: YawReference | None) -> None:
        """Per stage: the extrapolated set-point, its course (psi_ref; the yaw reference instead when given), the
        working servos and the bank of a coordinated turn (phi_ref)."""
        solver, params = self.solver, self.params
        rate = self.trajectory.update(time_usec, v_sp)
        v_sp = self.trajectory.now(time_usec)
        turning = self.horizon.turning_setpoint
        times_s = solver.grid.times_s
        params[P_V_SP, :], rates = extrapolate_setpoint(v_sp, rate, times_s, turning)
        params[P_FREE_TILT, :] = np.isnan(self.servos.stuck)[:, None]
        if reference is None:
            north, east = float(params[P_V_SP.start, 0]), float(params[P_V_SP.start + 1, 0])
            self.yaw_hold = held_yaw(self.yaw_hold, yaw, bool(has_course(north, east)))
            psi_ref = yaw_references(params[P_V_SP, :], yaw + wrap(self.yaw_hold - yaw))
            turn_rate = course_rates(params[P_V_SP, :], rates)  # while it has a course (psi_ref follows it)
        else:  # each stage within pi of the one before, stage 0 of the (continuous) yaw
            self.yaw_hold = yaw
            psi_ref = angle_chain(yaw, reference.at(times_s), np.ones(times_s.size, dtype=bool))
            turn_rate = np.full(times_s.size, reference.rate)
        params[P_PSI_REF, :] = psi_ref
        params[P_PHI_REF, :] = coordinated_roll(rates, psi_ref, self.airframe.gravity, self.limits.attitude[0])
        params[P_PSI_RATE_REF, :] = turn_rate
        # The yaw set-point that holds the attitude loop on a yaw turning at turn_rate: it leads by rate / K_att.
        params[P_PSI_D_REF, :] = psi_ref + turn_rate / solver.gains.attitude[2]

    def update(self, state: VehicleState, v_sp: np.ndarray, tilts: np.ndarray,
               yaw_ref: YawReference | None = None) -> VelocityCommand:  # fmt: skip
        x0 = self._prepare(state, v_sp, tilts, yaw_ref)
        return self._command(self.solver.solve(x0, self.params))

    def start(self, state: VehicleState, v_sp: np.ndarray, tilts: np.ndarray,
              yaw_ref: YawReference | None = None) -> None:  # fmt: skip
        """`update` in two halves: the solve runs on the solver's worker thread until `finish` (mpc/overlap.py)."""
        self.solver.start(self._prepare(state, v_sp, tilts, yaw_ref), self.params)

    def finish(self) -> VelocityCommand:
        """The command of the solve `start` began."""
        return self._command(self.solver.finish())

    def _prepare(self, state: VehicleState, v_sp: np.ndarray, tilts: np.ndarray,
                 yaw_ref: YawReference | None) -> np.ndarray:  # fmt: skip
        """The tick up to its solve: the warm start shifted, x0 (returned), the bounds and the stage parameters."""
        rates = euler_rates(state.euler, state.body_rates)
        previous = rates if self.previous_rates is None else self.previous_rates
        self.previous_rates = rates
        solver = self.solver
        yaw = float(state.euler[2])
        if solver.initialised:
            solver.shift()
            # Keep the plan's yaw continuous: the measured yaw jumps by 2 pi at +-180 deg, the plan must not (a
            # 2 pi gap between x_0 and the warm start made the solves fail there). Unwrap the measurement to the
            # plan and keep the plan within a turn of zero.
            planned = float(solver.w[PSI_INDEX])
            if abs(planned) > 2 * math.pi:
                turns = 2 * math.pi * round(planned / (2 * math.pi))
                solver.shift_yaw(-turns)
                planned -= turns
            yaw = planned + wrap(yaw - planned)
        euler = np.array([state.euler[0], state.euler[1], yaw])
        x0 = np.concatenate((state.velocity_ned, tilts, euler, rates, previous))
        self.last_x0 = x0
        self._bounds_from_health()
        self._set_parameters(v_sp, yaw, state.time_usec, yaw_ref)
        if not solver.initialised:
            solver.initialise(x0, self.airframe.hover_thrust_per_rotor)
            for _ in range(WARM_UP_ITERATIONS):
                solver.solve(x0, self.params)
        return x0

    def _command(self, solution: MpcSolution) -> VelocityCommand:
        """The solved tick's first stage as the command; a failed solve counted."""
        self.solve_times.add(solution.solve_time_s)
        self.last_solution = solution
        if solution.ok:
            self.failures_in_row = 0
        else:  # fly on the shifted previous plan (already in the solver's guess)
            self.failures_in_row += 1
            self.solves_failed += 1
            if self.failures_in_row >= MAX_FAILURES:
                self.fallback_requested = True
        states, inputs = solution.x, solution.u  # the plan as the solve left it (nothing has run since)
        u0 = inputs[0]
        command = VelocityCommand(mode="MPC")
        command.euler_sp[:] = u0[PSI_D]
        command.euler_sp[2] = wrap(u0[PSI_D][2])
        command.tilt_sp[:] = states[self.tilt_lead_stages][CHI]
        command.force_sp_body[:] = self.force_function(states[0], u0)[0]
        command.force_weights[:] = 1.0
        return command

    def solution_summary(self) -> dict:
        """The latest solve's telemetry payload (solution_summary)."""
        return solution_summary(self.last_solution)

    def statistics(self) -> dict:
        """The solver metrics of a flight's summary: solve time median / p99 (within the sketch's 1 %) / max (ms),
        the failed solves."""
        return {**self.solve_times.summary_ms(), "solves_failed": self.solves_failed}


def solution_summary(solution: MpcSolution) -> dict:
    """Telemetry payload of one solve (docs/telemetry.md): predicted velocities and tilts, solve time, iterations,
    status."""
    return {
        "ok": solution.ok,
        "status": solution.status,
        "solve_time_ms": solution.solve_time_s * 1e3,
        "qp_iterations": solution.iterations,
        "cost": solution.cost,
        "predicted_velocity": solution.x[:, V].tolist(),
        "predicted_tilt": solution.x[:, CHI].tolist(),
        "thrust": solution.u[0][THRUST].tolist(),
        "attitude_sp": solution.u[0][PSI_D].tolist(),
    }
