"""The autopilot's control core: velocity controller at 100 Hz, attitude loop and allocation at 250 Hz, in
simulation time, producing the 12 actuator commands of every 400 Hz plant step (docs/autopilot.md).

    measured velocity  --(400 Hz)--> VelocityEstimate (accelerometer-aided) --> the velocity the controllers use
    velocity set-point --(100 Hz)--> velocity controller --> attitude set-point, tilts, force set-point
    attitude set-point --(250 Hz)--> attitude loop --> torque set-point
    (force, torque)    --(250 Hz)--> QP allocation --> rotor thrusts, surfaces
    tilts                         --> tilt servos directly (not allocated)

The 250 Hz tasks run on the 400 Hz plant clock whenever their 4 ms period has elapsed (so 2.5 or 5 ms apart,
250 Hz on average); the 100 Hz task runs every fourth step exactly. The velocity controllers, the allocator and
the servo estimate are built by autopilot.controllers.build_flight_controller and passed in.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from aircraft.actuators import ALLOCATED_ROTORS, CHANNELS, TILTS, set_allocated
from aircraft.airframe import Airframe
from aircraft.failures import Failure
from aircraft.rotors import rotor_wrench
from autopilot.control.actuator_health import ActuatorHealth, ServoEstimate
from autopilot.control.allocation import ControlAllocator
from autopilot.control.attitude import AttitudeController, AttitudeGains
from autopilot.control.attitude_setpoint import attitude_command
from autopilot.control.pid_baseline import PidVelocityController
from autopilot.control.tuning import attitude_gains, pid_parameters
from autopilot.control.velocity_command import VelocityCommand
from autopilot.control.velocity_controller import PrimaryVelocityController, VelocityController
from autopilot.control.velocity_estimate import VelocityEstimate
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.attitude_target import AttitudeTarget
from autopilot.topics.controller_kind import MPC, PID, ControllerKind
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawReference

VELOCITY_PERIOD_USEC = 10_000  # 100 Hz
ATTITUDE_PERIOD_USEC = 4_000  # 250 Hz
# Priorities when the demand is infeasible, as PX4's allocation has them: roll and pitch first (1 N m of
# error costs like 10 N of force error), then thrust, yaw last (1 N m like 1 N).
MOMENT_WEIGHTS = (100.0, 100.0, 1.0)
YAW_MOMENT_ROW = 5  # of the allocator's wrench (force, moment)


class YawByTilt:
    """Hover yaw by differential tilt, as PX4 flies tiltrotors: the yaw the allocator could not make (the rotors'
    reaction torque is only 0.05 of thrust) is integrated into opposite tilts of the rotors on either side.

    The pattern and its yaw moment come from the rotor model, as PX4's ActuatorEffectivenessTilts derives its tilts'
    yaw effect from the rotor positions: each rotor tilts the way that yaws the aircraft positive, and a tilt d of
    the pattern makes a yaw moment of (sum over the rotors of |d yaw / d tilt| per newton) T d, no net force.
    """

    GAIN = 0.05  # per 250 Hz tick: the residual is integrated with a ~80 ms time constant
    MAX = np.radians(35.0)

    def __init__(self, airframe: Airframe) -> None:
        self.thrust_max = airframe.thrust_max
        self.thrust_min = airframe.yaw_tilt_thrust_min
        tilts = ca.SX.sym("tilts", len(airframe.rotor_positions))
        _, moment = rotor_wrench(airframe, ca.DM.ones(tilts.numel()), tilts)
        yaw_per_tilt = ca.Function("yaw_per_tilt", [tilts], [ca.jacobian(moment[2], tilts)])
        per_newton = np.asarray(yaw_per_tilt(np.zeros(tilts.numel()))).ravel()  # N m / (rad N) at tilt 0
        self.pattern = np.sign(per_newton)
        self.moment_per_tilt = float(self.pattern @ per_newton)  # N m / (rad N)
        self.tilt = 0.0  # rad along the pattern

    def update(self, active: bool, yaw_residual: float, thrust_fractions: np.ndarray) -> None:
        """One attitude tick: integrate the yaw residual (N m) while active, else hand back smoothly."""
        if not active:
            self.tilt *= 1.0 - self.GAIN  # hand back to the velocity controller's tilts smoothly
            return
        mean = float(thrust_fractions.sum()) / thrust_fractions.size  # np.mean's sum and division, without its wrapper
        thrust = max(mean * self.thrust_max, self.thrust_min)
        self.tilt += self.GAIN * yaw_residual / (self.moment_per_tilt * thrust)
        self.tilt = min(max(self.tilt, -self.MAX), self.MAX)

    @property
    def offsets(self) -> np.ndarray:
        """What to add to the velocity controller's tilts (rad)."""
        return self.tilt * self.pattern


class FlightController:
    """Velocity set-point in, physical actuator commands out (thrust fractions, tilts rad, deflections).

    Flies `mpc` when given (synchronous, the paper's way, or overlapped: autopilot/mpc/overlap.py), with `pid` as
    its back-up after repeated failed solves (paper), else `pid`.
    """

    def __init__(
        self,
        airframe: Airframe,
        allocator: ControlAllocator,
        servos: ServoEstimate,
        pid: PidVelocityController,
        mpc: PrimaryVelocityController | None = None,
    ) -> None:
        self.airframe = airframe
        self.allocator = allocator
        self.servos = servos
        self.pid = pid
        self.mpc = mpc
        self.velocity_controller: VelocityController = pid if mpc is None else mpc  # the one flying
        self.attitude = AttitudeController(airframe)
        self.health = ActuatorHealth(airframe, allocator, servos)
        self.yaw_tilt = YawByTilt(airframe)
        self.fell_back_to_pid = False
        self.events: list[str] = []  # what the vehicle should announce (STATUSTEXT), taken by pop_events()
        self.velocity_command = VelocityCommand()
        self.velocity_estimate = VelocityEstimate(airframe.gravity)
        self.velocity_setpoint = np.zeros(3)
        self.yaw_reference: YawReference | None = None  # None: the velocity controller's own yaw rule
        self.attitude_setpoint: AttitudeTarget | None = None  # Offboard attitude: the velocity controller idles
        self.command = np.zeros(CHANNELS)
        set_allocated(self.command, allocator.u)  # rotors and surfaces where the allocator starts
        self.torque_sp = np.zeros(3)
        self.wrench_sp = np.zeros(6)
        self.residual = np.zeros(6)
        self.allocation_fallbacks = 0
        self._next_velocity_usec: int | None = None
        self._next_attitude_usec = 0
        self._servo_time_usec = 0
        self._weights = np.array([1.0, 1.0, 1.0, *MOMENT_WEIGHTS])
        self.allocator.set_wrench_weights(self._weights)

    @property
    def kind(self) -> ControllerKind:
        """What was built: "mpc" (with the PID as back-up) or "pid"."""
        return PID if self.mpc is None else MPC

    @property
    def mode(self) -> str:
        return self.velocity_command.mode

    @property
    def mode_switches(self) -> int:
        """The flying velocity controller's phase changes."""
        return self.velocity_controller.mode_switches

    @property
    def attitude_gains(self) -> AttitudeGains:
        """The attitude loop's gains flown now."""
        return self.attitude.gains

    def set_velocity_setpoint(self, velocity_ned: np.ndarray) -> bool:
        """Accept a NED velocity set-point (m/s); a non-finite one is refused (False) and the last one kept."""
        if not np.all(np.isfinite(velocity_ned)):
            return False
        self.velocity_setpoint[:] = velocity_ned
        return True

    def set_yaw_reference(self, reference: YawReference | None) -> bool:
        """The yaw the velocity controller follows (None: its own rule); a non-finite one is refused (False) and the
        controller's own rule flies."""
        if reference is not None and not (math.isfinite(reference.yaw) and math.isfinite(reference.rate)):
            self.yaw_reference = None
            return False
        self.yaw_reference = reference
        return True

    def set_attitude_setpoint(self, target: AttitudeTarget | None) -> None:
        """Offboard attitude: fly `target` with the attitude loop alone (None: the velocity controller flies)."""
        self.attitude_setpoint = target

    def retune(self, params: ParameterStore) -> None:
        """The parameters' gains and limits from the next tick on, in flight too: the attitude loop's (MC_*), the PID
        baseline's (flying, or the MPC's back-up), the MPC's (VT_MPC_*, and its model of the attitude loop)."""
        self.attitude.set_gains(attitude_gains(params))
        self.pid.set_parameters(pid_parameters(params))
        if self.mpc is not None:
            self.mpc.retune(params)

    def apply_failure(self, failure: Failure) -> None:
        """Tell the allocator and the servo estimate about a failure the plant accepted."""
        self.health.apply(failure)
        if self.mpc is not None:
            self.mpc.health_changed(self.allocator, self.servos)

    def pop_events(self) -> list[str]:
        """Events since the last call (the MPC falling back to the PID), for STATUSTEXT."""
        events, self.events = self.events, []
        return events

    def controller_statistics(self) -> dict:
        """The MPC's solver metrics and whether the PID took over; empty for the PID alone."""
        if self.mpc is None:
            return {}
        return {**self.mpc.statistics(), "fell_back_to_pid": self.fell_back_to_pid}

    def restart_clock(self) -> None:
        """The plant's clock went back (a new plant run): schedule the tasks afresh from the next step."""
        self._next_velocity_usec = None

    def velocity_due(self, time_usec: int) -> bool:
        """True when the velocity controller runs at this plant step (the set-point is read then)."""
        return self._next_velocity_usec is None or time_usec >= self._next_velocity_usec

    def step(self, state: VehicleState) -> bool:
        """Run the tasks due at the plant step state.time_usec (call once per step, in time order).

        Returns True when `command` changed (at the 250 Hz ticks); between ticks the command holds.
        """
        t = state.time_usec
        if self._next_velocity_usec is None:
            self._next_velocity_usec = self._next_attitude_usec = self._servo_time_usec = t
        velocity = self.velocity_estimate.update(state)
        if t >= self._next_velocity_usec or t >= self._next_attitude_usec:
            state = state.with_velocity(velocity.copy())  # the controllers fly on the estimate
        if t >= self._next_velocity_usec:
            self._next_velocity_usec += VELOCITY_PERIOD_USEC
            tilts = self._velocity_controller_tilts()
            if self.attitude_setpoint is None:
                self.velocity_command = self.velocity_controller.update(state, self.velocity_setpoint, tilts,
                                                                        self.yaw_reference)  # fmt: skip
            else:  # the velocity controller tracks the vehicle's own velocity, warm for when it flies again
                self.velocity_controller.update(state, state.velocity_ned, tilts)
                self.velocity_command = attitude_command(
                    self.attitude_setpoint,
                    state.euler,
                    self.airframe.thrust_max * len(self.airframe.rotor_positions),
                    self.attitude.gains,
                )
            if self.mpc is not None and self.mpc.fallback_requested and not self.fell_back_to_pid:
                self._fall_back_to_pid(state, self.mpc)
        if t < self._next_attitude_usec:
            return False
        self._next_attitude_usec += ATTITUDE_PERIOD_USEC
        # The servos have been following the tilt command sent since the last tick: advance the estimate.
        self.servos.advance(self.command[TILTS], (t - self._servo_time_usec) / 1e6)
        self._servo_time_usec = t
        self._attitude_and_allocation(state)
        self.command[TILTS] = self.velocity_command.tilt_sp + self.yaw_tilt.offsets
        return True

    def _velocity_controller_tilts(self) -> np.ndarray:
        """The tilts as the flying velocity controller sees them. The MPC plans from the tilts it commanded: the
        servo estimate without the yaw-by-tilt offsets (a stuck servo's as it is), else the next plan would start
        from the offsets and command them again on top; within the tilt range, as its plans are (a start outside
        it made every QP infeasible). The PID's phase logic reads the estimate as it is."""
        if self.velocity_controller is self.pid:
            return self.servos.tilt
        own = self.servos.tilt - np.where(np.isnan(self.servos.stuck), self.yaw_tilt.offsets, 0.0)
        return np.clip(own, self.airframe.tilt_min, self.airframe.tilt_max)

    def _yaw_by_tilt(self, command: VelocityCommand) -> bool:
        """Whether differential tilt takes the yaw the allocator cannot make: when the velocity controller asks
        (the PID's hover), and under the MPC when a servo is stuck. The MPC plans the tilts for force alone; a
        rotor stuck tilted forward at low speed makes a yaw moment the rotors' reaction torque cannot hold, and the
        aircraft spun up and fell (servo-jam campaign: 60-95 deg jams at 1-9 m/s)."""
        return command.yaw_by_tilt or (self.velocity_controller is not self.pid and self.servos.any_stuck)

    def _fall_back_to_pid(self, state: VehicleState, mpc: PrimaryVelocityController) -> None:
        """Paper: the PID is the MPC's back-up after repeated failed solves; it flies from this tick on."""
        self.fell_back_to_pid = True
        self.velocity_controller = self.pid
        self.events.append(f"MPC: {mpc.failures_in_row} failed solves in a row, PID back-up flying")
        self.velocity_command = self.pid.update(state, self.velocity_setpoint, self.servos.tilt, self.yaw_reference)

    def _attitude_and_allocation(self, state: VehicleState) -> None:
        command = self.velocity_command
        self.torque_sp = self.attitude.update(state.euler, state.body_rates, command.euler_sp)
        if self._weights[0:3].tolist() != command.force_weights.tolist():  # NaN differs too, as array_equal
            self._weights[0:3] = command.force_weights
            self.allocator.set_wrench_weights(self._weights)
        v_air_body = state.rotation().T @ state.velocity_ned  # no wind estimate: ground velocity as airspeed
        self.wrench_sp = np.concatenate((command.force_sp_body, self.torque_sp))
        result = self.allocator.allocate(self.wrench_sp, self.servos.tilt, v_air_body, state.body_rates)
        if result.fallback:
            self.allocation_fallbacks += 1
        self.residual = result.residual
        self.yaw_tilt.update(self._yaw_by_tilt(command), result.residual[YAW_MOMENT_ROW], result.u[ALLOCATED_ROTORS])
        set_allocated(self.command, result.u)
