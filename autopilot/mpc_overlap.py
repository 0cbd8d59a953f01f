"""The MPC's solve overlapped with the plant's steps: a fixed one-tick computation delay (docs/mpc.md 3.9).

The paper solves at tick k from the state measured at tick k and applies the plan at once, as if the solve took
no time. Here the solve of tick k+1 runs in a second process (on the second core) while the autopilot runs the
400 Hz steps between the ticks:

    tick k:  take the command solved for tick k (started at tick k-1); it flies from now
             predict x_{k+1} = F(x_k, u_k): the MPC's own model over one control period from the measured state
             x_k with the input u_k of the plan now flying (delay compensation, as real autopilots have)
             start the solve from x_{k+1}, with the set-point carried one period along its trajectory

The first tick solves at once. The solving process is forked from the autopilot with the controller built, and
owns it from then on: it receives the requests in order and nothing else, and the failure state the MPC's bounds
come from (HealthSnapshot) after each failure, so the commands are the same run to run, bit for bit. A worker
thread would share the autopilot's heap, whose layout would then depend on timing, while the allocation QP's last
bits depend on its buffers' alignment (docs/mpc.md 3.9). The paper's synchronous way: VT_MPC_OVERLAP = 0.
"""

from __future__ import annotations

import math
import multiprocessing
import signal
import traceback
import weakref
from dataclasses import dataclass
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess

import numpy as np

from aircraft.codegen import BufferedFunction
from aircraft.frames import quaternion_from_euler
from autopilot.actuator_health import ServoEstimate
from autopilot.allocation import ControlAllocator
from autopilot.attitude import wrap
from autopilot.mpc import MpcSolution
from autopilot.mpc_controller import MpcVelocityController, euler_rates
from autopilot.mpc_model import CHI, PSI, PSI_DOT, PSI_INDEX, V, discrete_dynamics
from autopilot.vehicle_state import VehicleState
from autopilot.velocity_command import SetpointTrajectory, VelocityCommand
from autopilot.yaw_setpoint import YawReference

STOP_WAIT_S = 5.0


def body_rates(euler: np.ndarray, rates: np.ndarray) -> np.ndarray:
    """omega = E(Psi) Psi_dot for ZYX Euler angles: the inverse of mpc_controller.euler_rates."""
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


@dataclass(frozen=True)
class HealthSnapshot:
    """What the MPC's bounds are made of (MpcVelocityController._bounds_from_health): the allocator's per-actuator
    effectiveness and bounds, the servo estimate's stuck angles and rate fractions."""

    effectiveness: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    stuck: np.ndarray
    rate_scale: np.ndarray

    @staticmethod
    def of(allocator: ControlAllocator, servos: ServoEstimate) -> HealthSnapshot:
        return HealthSnapshot(allocator.effectiveness, allocator.lower, allocator.upper, servos.stuck.copy(),
                              servos.rate_scale.copy())  # fmt: skip

    def apply_to(self, allocator: ControlAllocator, servos: ServoEstimate) -> None:
        for i, (fraction, lower, upper) in enumerate(zip(self.effectiveness, self.lower, self.upper)):
            allocator.clear(i)
            allocator.set_effectiveness(i, fraction)
            allocator.set_actuator_limit(i, lower, upper)
        servos.stuck[:] = self.stuck
        servos.rate_scale[:] = self.rate_scale


@dataclass(frozen=True)
class SolveRequest:
    state: VehicleState
    v_sp: np.ndarray
    tilts: np.ndarray
    previous_rates: np.ndarray  # the MPC's Psi_dot_prev for this state: the rates of the tick before
    yaw_ref: YawReference | None  # the yaw asked for at this state's tick (None: the MPC's own rule)


@dataclass(frozen=True)
class SolveReply:
    command: VelocityCommand
    solution: MpcSolution | None
    fallback_requested: bool
    failures_in_row: int


@dataclass(frozen=True)
class SolveError:
    trace: str


STATISTICS = "statistics"  # the request for MpcVelocityController.statistics()


def serve(mpc: MpcVelocityController, connection: Connection, parent_end: Connection) -> None:
    """The solving process: requests in order until the stop (None) or the autopilot's end of the pipe closes."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the autopilot handles Ctrl-C and then stops this process
    parent_end.close()
    while True:
        try:
            request = connection.recv()
        except EOFError:
            return
        if request is None:
            return
        if isinstance(request, HealthSnapshot):
            request.apply_to(mpc.allocator, mpc.servos)
            continue
        if request == STATISTICS:
            connection.send(mpc.statistics())
            continue
        try:
            mpc.previous_rates = request.previous_rates
            command = mpc.update(request.state, request.v_sp, request.tilts, request.yaw_ref)
            reply: SolveReply | SolveError = SolveReply(command, mpc.last_solution, mpc.fallback_requested,
                                                        mpc.failures_in_row)  # fmt: skip
        except Exception:  # handed to the autopilot, which raises it
            reply = SolveError(traceback.format_exc())
        try:
            connection.send(reply)
        except BrokenPipeError:
            return  # the autopilot stopped while this solve ran


def _stop(connection: Connection, process: BaseProcess) -> None:
    try:
        connection.send(None)
    except OSError:
        pass  # the process has gone already: nothing to stop
    connection.close()
    process.join(STOP_WAIT_S)
    if process.is_alive():
        process.kill()
        process.join()


class OverlappedMpc:
    """MpcVelocityController solving one tick ahead in a process of its own (a VelocityController)."""

    def __init__(self, mpc: MpcVelocityController, period_usec: int) -> None:
        self.airframe = mpc.airframe
        self.limits = mpc.limits  # what its plans keep to
        self.period_usec = period_usec
        self._predict = BufferedFunction(discrete_dynamics(mpc.airframe, mpc.solver.gains))
        self._tick_grid = np.array([period_usec / 1e6, 1.0])  # one control tick, the previous rate held over it
        context = multiprocessing.get_context("fork")
        self._connection, child_end = context.Pipe()
        self._process = context.Process(target=serve, args=(mpc, child_end, self._connection), daemon=True,
                                        name="vtol-autopilot-mpc")  # fmt: skip
        self._process.start()
        child_end.close()
        self._finalizer = weakref.finalize(self, _stop, self._connection, self._process)
        self._in_flight = False
        self._held: SolveReply | None = None  # a solve's reply taken early (statistics), for its tick
        self._trajectory = SetpointTrajectory()
        self._previous_rates: np.ndarray | None = None
        self.mode_switches = 0  # the MPC has no modes
        self.last_solution: MpcSolution | None = None
        self.fallback_requested = False
        self.failures_in_row = 0

    @property
    def pid(self) -> int | None:
        """The solving process's id."""
        return self._process.pid

    def update(self, state: VehicleState, v_sp: np.ndarray, tilts: np.ndarray,
               yaw_ref: YawReference | None = None) -> VelocityCommand:  # fmt: skip
        """The command solved one tick ago for this tick (the first tick: solved now); starts the next solve."""
        rates = euler_rates(state.euler, state.body_rates)
        previous = rates if self._previous_rates is None else self._previous_rates
        self._previous_rates = rates
        self._trajectory.update(state.time_usec, v_sp)
        if not self._in_flight and self._held is None:
            self._send(SolveRequest(state, v_sp.copy(), tilts.copy(), previous, yaw_ref))
        reply, self._held = self._held or self._receive(), None
        self.last_solution = reply.solution
        self.fallback_requested, self.failures_in_row = reply.fallback_requested, reply.failures_in_row
        solution = reply.solution
        if solution is None:
            return reply.command
        plan_yaw = float(solution.x[0][PSI_INDEX])  # the plan's yaw is unwrapped, the measurement is not
        euler = np.array([state.euler[0], state.euler[1], plan_yaw + wrap(float(state.euler[2]) - plan_yaw)])
        x_now = np.concatenate((state.velocity_ned, tilts, euler, rates, previous))
        x_next = self._predict(x_now, solution.u[0], self._tick_grid)[0].copy()
        next_tilts = np.clip(x_next[CHI], self.airframe.tilt_min, self.airframe.tilt_max)
        next_state = predicted_state(state, x_next, self.period_usec)
        # At tick k+1 the previous tick's rates are the ones measured now; the yaw reference has turned on by a tick.
        next_yaw_ref = None if yaw_ref is None else YawReference(yaw_ref.at(self.period_usec / 1e6), yaw_ref.rate)
        self._send(SolveRequest(next_state, self._trajectory.now(next_state.time_usec), next_tilts, rates,
                                next_yaw_ref))  # fmt: skip
        return reply.command

    def health_changed(self, allocator: ControlAllocator, servos: ServoEstimate) -> None:
        """A failure became known: the solves from the next one on use the new bounds."""
        self._connection.send(HealthSnapshot.of(allocator, servos))

    def statistics(self) -> dict:
        """The MPC's solver metrics (mpc_controller), the solve in flight included."""
        if self._in_flight:
            self._held = self._receive()
        self._connection.send(STATISTICS)
        return self._connection.recv()

    def close(self) -> None:
        """Stop the solving process (also done when this object is collected)."""
        self._finalizer()

    def _send(self, request: SolveRequest) -> None:
        self._connection.send(request)
        self._in_flight = True

    def _receive(self) -> SolveReply:
        try:
            reply = self._connection.recv()
        except EOFError:
            raise RuntimeError(f"the MPC's solving process (pid {self.pid}) has exited") from None
        self._in_flight = False
        if isinstance(reply, SolveError):
            raise RuntimeError(f"the MPC's solve failed in its process:\n{reply.trace}")
        return reply
