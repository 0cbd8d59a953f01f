"""The autopilot's control core: velocity controller at 100 Hz, attitude loop and allocation at 250 Hz, in
simulation time, producing the 12 actuator commands of every 400 Hz plant step (SPEC section 4).

    measured velocity  --(400 Hz)--> VelocityEstimate (accelerometer-aided) --> the velocity the controllers use
    velocity set-point --(100 Hz)--> velocity controller --> attitude set-point, tilts, force set-point
    attitude set-point --(250 Hz)--> attitude loop --> torque set-point
    (force, torque)    --(250 Hz)--> QP allocation --> rotor thrusts, surfaces
    tilts                         --> tilt servos directly (not allocated)

The 250 Hz tasks run on the 400 Hz plant clock whenever their 4 ms period has elapsed (so 2.5 or 5 ms apart,
250 Hz on average); the 100 Hz task runs every fourth step exactly.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from aircraft.airframe import Airframe
from autopilot.actuator_health import ActuatorHealth, ServoEstimate
from autopilot.allocation import ControlAllocator
from autopilot.attitude import AttitudeController
from autopilot.mpc_controller import MpcVelocityController, solve_statistics
from autopilot.pid_baseline import PidVelocityController
from autopilot.vehicle_state import VehicleState
from autopilot.velocity_command import VelocityCommand
from autopilot.velocity_estimate import VelocityEstimate

VELOCITY_PERIOD_USEC = 10_000  # 100 Hz
ATTITUDE_PERIOD_USEC = 4_000  # 250 Hz
# Differential tilt for hover yaw: tilting the right rotors (1, 2) back and the left ones (3, 4) forward by d
# makes a yaw moment of about 2 T d (rotor arms 0.5 m to each side) and no net force.
YAW_TILT_PATTERN = np.array([-1.0, -1.0, 1.0, 1.0])
YAW_TILT_GAIN = 0.05  # per 250 Hz tick: the residual is integrated with a ~80 ms time constant
YAW_TILT_MAX = np.radians(35.0)
# Priorities when the demand is infeasible, as PX4's allocation has them: roll and pitch first (1 N m of
# error costs like 10 N of force error), then thrust, yaw last (1 N m like 1 N).
MOMENT_WEIGHTS = (100.0, 100.0, 1.0)


class FlightController:
    """Velocity set-point in, physical actuator commands out (thrust fractions, tilts rad, deflections)."""

    def __init__(self, airframe: Airframe, controller: str = "pid") -> None:
        """controller: "mpc" (the unified MPC, with the PID as its back-up) or "pid" (the baseline alone)."""
        if controller not in ("mpc", "pid"):
            raise ValueError(f"controller must be 'mpc' or 'pid', got {controller!r}")
        self.airframe = airframe
        hover = airframe.hover_thrust_per_rotor / airframe.thrust_max
        self.allocator = ControlAllocator(airframe, u_initial=[hover] * 4 + [0.0] * 4)
        self.attitude = AttitudeController(airframe)
        self.servos = ServoEstimate(airframe)
        self.pid = PidVelocityController(airframe, dt=VELOCITY_PERIOD_USEC / 1e6)
        self.mpc = MpcVelocityController(airframe, self.allocator, self.servos) if controller == "mpc" else None
        self.velocity_controller: PidVelocityController | MpcVelocityController = self.mpc or self.pid
        self.fell_back_to_pid = False
        self.events: list[str] = []  # what the vehicle should announce (STATUSTEXT), taken by pop_events()
        self.health = ActuatorHealth(airframe, self.allocator, self.servos)
        self.velocity_command = VelocityCommand()
        self.velocity_estimate = VelocityEstimate(airframe.gravity)
        self.velocity_setpoint = np.zeros(3)
        self.command = np.zeros(12)
        self.command[0:4] = hover
        self.torque_sp = np.zeros(3)
        self.wrench_sp = np.zeros(6)
        self.residual = np.zeros(6)
        self.allocation_fallbacks = 0
        self._next_velocity_usec: int | None = None
        self._next_attitude_usec = 0
        self._servo_time_usec = 0
        self._weights = np.array([1.0, 1.0, 1.0, *MOMENT_WEIGHTS])
        self.yaw_tilt = 0.0  # rad: right rotors tilted back and left rotors forward by this much (yaw_by_tilt)
        self.allocator.set_wrench_weights(self._weights)

    @property
    def mode(self) -> str:
        return self.velocity_command.mode

    def set_velocity_setpoint(self, velocity_ned: np.ndarray) -> bool:
        """Accept a NED velocity set-point (m/s); a non-finite one is refused (False) and the last one kept."""
        if not np.all(np.isfinite(velocity_ned)):
            return False
        self.velocity_setpoint[:] = velocity_ned
        return True

    def pop_events(self) -> list[str]:
        """Events since the last call (the MPC falling back to the PID), for STATUSTEXT."""
        events, self.events = self.events, []
        return events

    def controller_statistics(self) -> dict:
        """The MPC's solver metrics (SPEC 7) when it flies, else empty."""
        return {} if self.mpc is None else {**solve_statistics(self.mpc), "fell_back_to_pid": self.fell_back_to_pid}

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
            state = dataclasses.replace(state, velocity_ned=velocity.copy())  # the controllers fly on the estimate
        if t >= self._next_velocity_usec:
            self._next_velocity_usec += VELOCITY_PERIOD_USEC
            self.velocity_command = self.velocity_controller.update(state, self.velocity_setpoint, self.servos.tilt)
            if self.mpc is not None and self.mpc.fallback_requested and not self.fell_back_to_pid:
                # Paper: the PID is the MPC's back-up after repeated failed solves.
                self.fell_back_to_pid = True
                self.velocity_controller = self.pid
                self.events.append(f"MPC: {self.mpc.failures_in_row} failed solves in a row, PID back-up flying")
                self.velocity_command = self.pid.update(state, self.velocity_setpoint, self.servos.tilt)
        if t < self._next_attitude_usec:
            return False
        self._next_attitude_usec += ATTITUDE_PERIOD_USEC
        # The servos have been following the tilt command sent since the last tick: advance the estimate.
        self.servos.advance(self.command[4:8], (t - self._servo_time_usec) / 1e6)
        self._servo_time_usec = t
        self._attitude_and_allocation(state)
        self.command[4:8] = self.velocity_command.tilt_sp + self.yaw_tilt * YAW_TILT_PATTERN
        return True

    def _attitude_and_allocation(self, state: VehicleState) -> None:
        command = self.velocity_command
        self.torque_sp = self.attitude.update(state.euler, state.body_rates, command.euler_sp)
        if not np.array_equal(self._weights[0:3], command.force_weights):
            self._weights[0:3] = command.force_weights
            self.allocator.set_wrench_weights(self._weights)
        v_air_body = state.rotation().T @ state.velocity_ned  # no wind estimate: ground velocity as airspeed
        self.wrench_sp = np.concatenate((command.force_sp_body, self.torque_sp))
        result = self.allocator.allocate(self.wrench_sp, self.servos.tilt, v_air_body, state.body_rates)
        if result.fallback:
            self.allocation_fallbacks += 1
        self.residual = result.residual
        self._update_yaw_tilt(command.yaw_by_tilt, result.residual[5], result.u[0:4])
        self.command[0:4] = result.u[0:4]
        self.command[8:12] = result.u[4:8]

    def _update_yaw_tilt(self, active: bool, yaw_residual: float, thrust_fractions: np.ndarray) -> None:
        """Integrate the yaw the allocator could not make into a differential tilt (d/d tilt of yaw = 2 T)."""
        if not active:
            self.yaw_tilt *= 1.0 - YAW_TILT_GAIN  # hand back to the velocity controller's tilts smoothly
            return
        thrust = max(float(np.mean(thrust_fractions)) * self.airframe.thrust_max, 5.0)
        self.yaw_tilt += YAW_TILT_GAIN * yaw_residual / (2.0 * thrust)
        self.yaw_tilt = min(max(self.yaw_tilt, -YAW_TILT_MAX), YAW_TILT_MAX)

    def apply_failure(self, unit: int, kind: int, instance: int, value: float) -> None:
        """Tell the allocator and the servo estimate about a failure the plant accepted (SPEC section 5)."""
        self.health.apply(unit, kind, instance, value)
