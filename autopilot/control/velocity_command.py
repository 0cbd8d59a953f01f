"""What a velocity controller (the MPC or the PID baseline) hands to the attitude loop and the allocator."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

YAW_FROM_COURSE_SPEED = 3.0  # m/s: above this horizontal set-point speed the nose follows the set-point's course


def has_course(v_sp_north: float | np.ndarray, v_sp_east: float | np.ndarray) -> bool | np.ndarray:
    """The horizontal set-point is fast enough to have a course (each element's, for arrays)."""
    return np.hypot(v_sp_north, v_sp_east) > YAW_FROM_COURSE_SPEED


def setpoint_course(v_sp_north: float, v_sp_east: float) -> float | None:
    """The course (rad) both velocity controllers point the nose along (docs/mpc.md, the yaw reference: psi_ref), or None when the
    horizontal set-point is too slow to have one (then the controller keeps its yaw)."""
    if not has_course(v_sp_north, v_sp_east):
        return None
    return math.atan2(v_sp_east, v_sp_north)


class SetpointTrajectory:
    """The velocity set-point's trajectory over the horizon, extrapolated from the set-points received.

    The paper gives its MPC "an exact linear trajectory" of set-points; a set-point source here (the internal
    profile at 100 Hz, an offboard stream at >= 20 Hz) sends one velocity at a time. Its rate of change is
    estimated from consecutive distinct set-points, and the set-point is extrapolated linearly over the horizon:
    v_sp,k = v_sp + k dt a_sp. A jump faster than MAX_RATE is a step, not a ramp (rate 0), and the rate
    returns to 0 when the set-point stops changing (held for two of its update intervals).
    """

    MAX_RATE = 10.0  # m/s^2
    MAX_INTERVAL_S = 0.5  # set-points further apart than this are not a trajectory

    def __init__(self) -> None:
        self.last: np.ndarray | None = None
        self.last_usec = 0
        self.interval_s = 0.0
        self.rate = np.zeros(3)

    def update(self, time_usec: int, v_sp: np.ndarray) -> np.ndarray:
        """The set-point's rate of change (m/s^2, NED) at this tick."""
        if self.last is None:
            self.last, self.last_usec = v_sp.copy(), time_usec
        elif not np.array_equal(v_sp, self.last):
            interval = (time_usec - self.last_usec) / 1e6
            rate = (v_sp - self.last) / interval if 0.0 < interval <= self.MAX_INTERVAL_S else np.zeros(3)
            self.rate = rate if math.hypot(*rate.tolist()) <= self.MAX_RATE else np.zeros(3)
            self.interval_s = interval
            self.last, self.last_usec = v_sp.copy(), time_usec
        elif (time_usec - self.last_usec) / 1e6 > 1.5 * self.interval_s:
            self.rate = np.zeros(3)
        return self.rate

    def now(self, time_usec: int) -> np.ndarray:
        """The set-point carried on to `time_usec` along its rate (call after update() at that time).

        Set-points slower than the controllers' 100 Hz (50 Hz offboard) would otherwise hold for a tick and then
        jump: a reference that lags by 0 and 10 ms on alternate ticks, which the MPC answered with a 50 Hz
        alternation of its commands."""
        if self.last is None:
            return np.zeros(3)
        return self.last + self.rate * ((time_usec - self.last_usec) / 1e6)


def course_rates(v_sp: np.ndarray, rate: np.ndarray) -> np.ndarray:
    """course_rate at each column of v_sp (3, T) and rate (3, T)."""
    turning = v_sp[0] * rate[1] - v_sp[1] * rate[0]
    return np.divide(turning, v_sp[0] ** 2 + v_sp[1] ** 2, out=np.zeros_like(turning),
                     where=has_course(v_sp[0], v_sp[1]))  # fmt: skip


def course_rate(v_sp: np.ndarray, rate: np.ndarray) -> float:
    """How fast the set-point's course turns (rad/s) for a set-point v_sp changing at `rate` (m/s^2, NED):
    d/dt atan2(v_e, v_n); 0 while the set-point has no course (setpoint_course). The PID's, at every tick: on
    floats (course_rates through numpy costs 9 us a call here, this 1 us)."""
    if not has_course(v_sp[0], v_sp[1]):
        return 0.0
    return float((v_sp[0] * rate[1] - v_sp[1] * rate[0]) / (v_sp[0] ** 2 + v_sp[1] ** 2))


@dataclass
class VelocityCommand:
    """Outer-loop output, refreshed at 100 Hz (docs/autopilot.md).

    euler_sp: attitude set-point (roll, pitch, yaw) in rad for the attitude loop.
    tilt_sp: tilt servo set-points chi_1..4 in rad, sent straight to the servos (not allocated).
    force_sp_body: total non-gravity force wanted in body FRD (N), the force part of the allocator's wrench.
    force_weights: how much each body force row matters to the allocator; a PID mode that leaves a force
        axis to the attitude (e.g. lift by pitch in forward flight) weighs it 0.
    yaw_by_tilt: hover yaw by differential tilt, as PX4 flies tiltrotors: the rotors' reaction torque alone
        (0.05 of thrust) cannot hold heading against a rotor jammed tilted.
    """

    euler_sp: np.ndarray = field(default_factory=lambda: np.zeros(3))
    tilt_sp: np.ndarray = field(default_factory=lambda: np.zeros(4))
    force_sp_body: np.ndarray = field(default_factory=lambda: np.zeros(3))
    force_weights: np.ndarray = field(default_factory=lambda: np.ones(3))
    yaw_by_tilt: bool = False  # let differential tilt take the yaw the rotors' thrust cannot make (PID, hover)
    mode: str = ""  # the controller's phase name, for telemetry and mode-switch counting
