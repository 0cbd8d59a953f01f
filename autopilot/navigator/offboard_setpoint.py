"""The Offboard set-point as the commander keeps it: the latest velocity, position with a velocity
feed-forward (each with its yaw set-point, if any), or attitude (or body rates) with thrust, when it arrived (for the COM_OF_LOSS_T failsafe), and, with
`--offboard-lockstep`, the stamped velocity set-points waiting for their simulation time.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigator.stamped_setpoints import StampedSetpoints
from autopilot.topics.attitude_target import AttitudeTarget
from autopilot.topics.requests import OffboardAttitude, OffboardPosition, OffboardVelocity
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawSetpoint

SETPOINT_LIMITS = np.array([30.0, 30.0, 10.0])  # m/s: the MPC's velocity envelope; set-points are clamped to it
TILT_LIMIT = math.radians(45.0)  # rad: Offboard roll and pitch set-points are clamped to this
RATE_LIMIT = math.pi  # rad/s: the attitude loop's rate limit; body-rate and yaw-rate set-points are clamped to it


def attitude_in_limits(request: OffboardAttitude, last_thrust: float) -> tuple[AttitudeTarget, bool]:
    """The request clamped to TILT_LIMIT, RATE_LIMIT and thrust 0..1 (None: `last_thrust`); True when clamped."""
    thrust = last_thrust if request.thrust is None else request.thrust
    clamped_thrust = min(max(thrust, 0.0), 1.0)
    euler = rates = None
    clamped = clamped_thrust != thrust
    if request.euler is not None:
        euler = request.euler.copy()
        euler[0:2] = np.clip(euler[0:2], -TILT_LIMIT, TILT_LIMIT)
        clamped |= not np.array_equal(euler, request.euler)
    if request.body_rates is not None:
        rates = np.clip(request.body_rates, -RATE_LIMIT, RATE_LIMIT)
        clamped |= not np.array_equal(rates, request.body_rates)
    return AttitudeTarget(euler, rates, clamped_thrust), clamped


def yaw_in_limits(yaw: YawSetpoint | None) -> tuple[YawSetpoint | None, bool]:
    """The yaw rate clamped to RATE_LIMIT; True when clamped."""
    if yaw is None or yaw.rate is None or abs(yaw.rate) <= RATE_LIMIT:
        return yaw, False
    return YawSetpoint(yaw.heading, math.copysign(RATE_LIMIT, yaw.rate)), True


def to_ned(vector: np.ndarray, yaw: float) -> np.ndarray:
    """A vector of a yaw-rotated (body NED) frame in NED."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * vector[0] - s * vector[1], s * vector[0] + c * vector[1], vector[2]])


def in_envelope(velocity: np.ndarray, body: bool, yaw: float) -> tuple[np.ndarray, bool]:
    """A set-point in NED (rotated by the yaw when it is in a body frame), clamped to SETPOINT_LIMITS; True when
    it had to be clamped."""
    if body:
        velocity = to_ned(velocity, yaw)
    clamped = np.clip(velocity, -SETPOINT_LIMITS, SETPOINT_LIMITS)
    return clamped, not np.array_equal(clamped, velocity)


class OffboardSetpoint:
    def __init__(self, stamped: bool) -> None:
        self.velocity = np.zeros(3)  # NED, m/s (with a position: its feed-forward)
        self.position: np.ndarray | None = None  # NED from home, m; None: a velocity set-point
        self.attitude: AttitudeTarget | None = None  # SET_ATTITUDE_TARGET's (the velocity is then unused)
        self.yaw: YawSetpoint | None = None  # the velocity's or position's yaw set-point (None: none given)
        self.received_usec: int | None = None
        self.stamped = StampedSetpoints() if stamped else None
        self.clamped = 0  # set-points accept() had to clamp so far

    def accept(self, request: OffboardVelocity | OffboardPosition | OffboardAttitude, state: VehicleState,
               now_usec: int) -> bool:  # fmt: skip
        """A client's set-point in NED (body frames rotated by the yaw, offsets from where the vehicle is), its
        velocity clamped to the envelope, an attitude to its limits; True when it had to be clamped (counted)."""
        clamped = self._store(request, state, now_usec)
        self.clamped += clamped
        return clamped

    def _store(self, request: OffboardVelocity | OffboardPosition | OffboardAttitude, state: VehicleState,
               now_usec: int) -> bool:  # fmt: skip
        if isinstance(request, OffboardAttitude):
            last_thrust = 0.0 if self.attitude is None else self.attitude.thrust
            self.attitude, clamped = attitude_in_limits(request, last_thrust)
            self.velocity = np.zeros(3)
            self.position = None
            self.yaw = None
            self.received_usec = now_usec
            return clamped
        yaw = float(state.euler[2])
        velocity, clamped = in_envelope(request.velocity, request.body, yaw)
        yaw_setpoint, rate_clamped = yaw_in_limits(request.yaw)
        if isinstance(request, OffboardVelocity):
            self.receive(velocity, request.stamp_ms, now_usec, yaw_setpoint)
            return clamped or rate_clamped
        offset = to_ned(request.position, yaw) if request.body else request.position
        self.receive_position(state.position_ned + offset if request.relative else offset, velocity, now_usec,
                              yaw_setpoint)  # fmt: skip
        return clamped or rate_clamped

    def receive(self, velocity_ned: np.ndarray, stamp_ms: int | None, now_usec: int,
                yaw: YawSetpoint | None = None) -> None:  # fmt: skip
        """A set-point received now; a stamped one (--offboard-lockstep) takes effect at its time_boot_ms."""
        if self.stamped is not None and stamp_ms is not None:
            self.stamped.add(stamp_ms, (velocity_ned, yaw))
            return
        self.velocity = velocity_ned
        self.yaw = yaw
        self.position = None
        self.attitude = None
        self.received_usec = now_usec

    def receive_position(self, position_ned: np.ndarray, velocity_ned: np.ndarray, now_usec: int,
                         yaw: YawSetpoint | None = None) -> None:  # fmt: skip
        """A position set-point (NED from home) with its velocity feed-forward, received now."""
        self.position = position_ned
        self.velocity = velocity_ned
        self.yaw = yaw
        self.attitude = None
        self.received_usec = now_usec

    def take_due(self, time_usec: int) -> None:
        """The newest stamped set-point whose time has come takes effect."""
        if self.stamped is not None and (due := self.stamped.due(time_usec)) is not None:
            self.velocity, self.yaw = due
            self.position = None
            self.attitude = None
            self.received_usec = time_usec

    def covers(self, time_usec: int) -> bool:
        """--offboard-lockstep: the client's set-points reach this simulation time (True without the option)."""
        return self.stamped is None or self.stamped.covers(time_usec)

    def fresh(self, now_usec: int, loss_timeout_s: float) -> bool:
        """A set-point arrived within the loss timeout (COM_OF_LOSS_T)."""
        return self.received_usec is not None and now_usec - self.received_usec <= loss_timeout_s * 1e6

    def restart(self) -> None:
        """A new plant run: nothing received yet in its time."""
        self.received_usec = None
        if self.stamped is not None:
            self.stamped.clear()
