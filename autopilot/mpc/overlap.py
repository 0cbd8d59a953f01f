"""The MPC's solve overlapped with the plant's steps: a fixed one-tick computation delay (docs/mpc.md, options).

The paper solves at tick k from the state measured at tick k and applies the plan at once, as if the solve took
no time. Here the solve of tick k+1 runs on the solver's worker thread (on the second core) while the autopilot
runs the 400 Hz steps between the ticks:

    tick k:  take the command solved for tick k (started at tick k-1); it flies from now
             predict x_{k+1} = F(x_k, u_k): the MPC's own model over one control period from the measured state
             x_k with the input u_k of the plan now flying (delay compensation, as real autopilots have)
             start the solve from x_{k+1}, with the set-point carried one period along its trajectory

The first tick solves at once. The tick's Python (the warm start, the bounds from the failures known, the stage
parameters) runs here; the worker thread is the C back-end's own (autopilot/mpc/rti.c), which runs the
Gauss-Newton steps on copies of their inputs and writes only the C object's own buffers (no Python object, no
allocation), so the commands are the same run to run, bit for bit, whatever the timing. The paper's synchronous
way: VT_MPC_OVERLAP = 0.
"""

from __future__ import annotations

import math

import numpy as np

from aircraft.frames import quaternion_from_euler, wrap
from autopilot.control.actuator_health import ServoEstimate
from autopilot.control.allocation import ControlAllocator
from autopilot.control.attitude import euler_rates
from autopilot.control.velocity_command import SetpointTrajectory, VelocityCommand
from autopilot.mpc.controller import MpcVelocityController
from autopilot.mpc.model import CHI, PSI, PSI_DOT, PSI_INDEX, MpcLimits, V
from autopilot.mpc.rti import MpcSolution
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawReference


def body_rates(euler: np.ndarray, rates: np.ndarray) -> np.ndarray:
    """omega = E(Psi) Psi_dot for ZYX Euler angles: the inverse of control.attitude.euler_rates."""
    sf, cf = math.sin(euler[0]), math.cos(euler[0])
    st, ct = math.sin(euler[1]), math.cos(euler[1])
    roll_rate, pitch_rate, yaw_rate = rates
    return np.array([roll_rate - st * yaw_rate, cf * pitch_rate + sf * ct * yaw_rate,
                     -sf * pitch_rate + cf * ct * yaw_rate])  # fmt: skip


def predicted_state(state: VehicleState, x_next: np.ndarray, period_usec: int) -> VehicleState:
    """The vehicle state one control period on, from the MPC model's prediction x_next: velocity, attitude and
    rates predicted, the position carried along the mean velocity, the rest as measured."""
    euler = x_next[PSI].copy()
    euler[2] = wrap(float(euler[2]))
    period_s = period_usec / 1e6
    return VehicleState(
        time_usec=state.time_usec + period_usec,
        position_ned=state.position_ned + period_s * (state.velocity_ned + x_next[V]) / 2,
        velocity_ned=x_next[V].copy(),
        quaternion=np.array(quaternion_from_euler(*euler.tolist())),
        euler=euler,
        body_rates=body_rates(euler, x_next[PSI_DOT]),
        airspeed=state.airspeed,
        specific_force=state.specific_force.copy(),
        valid=state.valid,
    )


class OverlappedMpc:
    """MpcVelocityController solving one tick ahead on its solver's worker thread (a VelocityController)."""

    def __init__(self, mpc: MpcVelocityController, period_usec: int) -> None:
        self.mpc = mpc
        self.airframe = mpc.airframe
        self.period_usec = period_usec
        self._in_flight = False
        self._held: VelocityCommand | None = None  # a solve's command taken early (statistics), for its tick
        self._trajectory = SetpointTrajectory()
        self._previous_rates: np.ndarray | None = None
        self.mode_switches = 0  # the MPC has no modes

    @property
    def limits(self) -> MpcLimits:
        """What its plans keep to."""
        return self.mpc.limits

    def retune(self, params: ParameterStore) -> None:
        """The parameters' gains, weights and limits from the next solve started on."""
        self.mpc.retune(params)

    @property
    def last_solution(self) -> MpcSolution | None:
        return self.mpc.last_solution

    def solution_summary(self) -> dict:
        return self.mpc.solution_summary()

    @property
    def fallback_requested(self) -> bool:
        return self.mpc.fallback_requested

    @property
    def failures_in_row(self) -> int:
        return self.mpc.failures_in_row

    def update(self, state: VehicleState, v_sp: np.ndarray, tilts: np.ndarray,
               yaw_ref: YawReference | None = None) -> VelocityCommand:  # fmt: skip
        """The command solved one tick ago for this tick (the first tick: solved now); starts the next solve."""
        rates = euler_rates(state.euler, state.body_rates)
        previous = rates if self._previous_rates is None else self._previous_rates
        self._previous_rates = rates
        self._trajectory.update(state.time_usec, v_sp)
        if not self._in_flight and self._held is None:
            self._start(state, v_sp.copy(), tilts.copy(), previous, yaw_ref)
        command, self._held = self._held or self._finish(), None
        solution = self.mpc.last_solution
        if solution is None:
            return command
        plan_yaw = float(solution.x[0][PSI_INDEX])  # the plan's yaw is unwrapped, the measurement is not
        euler = np.array([state.euler[0], state.euler[1], plan_yaw + wrap(float(state.euler[2]) - plan_yaw)])
        x_now = np.concatenate((state.velocity_ned, tilts, euler, rates, previous))
        x_next = self.mpc.predict_tick(x_now, solution.u[0])
        next_tilts = np.clip(x_next[CHI], self.airframe.tilt_min, self.airframe.tilt_max)
        next_state = predicted_state(state, x_next, self.period_usec)
        # At tick k+1 the previous tick's rates are the ones measured now; the yaw reference has turned on by a tick.
        next_yaw_ref = None if yaw_ref is None else YawReference(yaw_ref.at(self.period_usec / 1e6), yaw_ref.rate)
        self._start(next_state, self._trajectory.now(next_state.time_usec), next_tilts, rates, next_yaw_ref)
        return command

    def health_changed(self, allocator: ControlAllocator, servos: ServoEstimate) -> None:
        """A failure became known: the solves from the next one on use the new bounds (the MPC reads them from the
        allocator and the servo estimate it shares, at the start of each solve)."""
        self.mpc.health_changed(allocator, servos)

    def statistics(self) -> dict:
        """The MPC's solver metrics (mpc/controller.py), the solve in flight included (waited for: its command is held
        for its tick, but the MPC's last solution and failure counts are that solve's from now on)."""
        if self._in_flight:
            self._held = self._finish()
        return self.mpc.statistics()

    def _start(self, state: VehicleState, v_sp: np.ndarray, tilts: np.ndarray, previous_rates: np.ndarray,
               yaw_ref: YawReference | None) -> None:  # fmt: skip
        self.mpc.previous_rates = previous_rates  # the MPC's Psi_dot_prev for this state: the rates of the tick before
        self.mpc.start(state, v_sp, tilts, yaw_ref)
        self._in_flight = True

    def _finish(self) -> VelocityCommand:
        self._in_flight = False
        return self.mpc.finish()
