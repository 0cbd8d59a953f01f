"""Yaw set-points shaped for the velocity controllers (docs/mavlink.md, Yaw), while the vehicle flies as a
multicopter.

    StickYaw       the yaw stick -> set-point: a rate while it is out, then the heading locked where the nose stopped
    YawShaper      set-point -> reference at 100 Hz: a heading is turned to at most the auto yaw rate
                   (MPC_YAWRAUTO_MAX, or faster when the set-point's own rate asks), a rate alone turns from where
                   the nose is; None above the multicopter speed, where the controllers point the nose along the
                   set-point's course
"""

from __future__ import annotations

import math

import numpy as np

from aircraft.frames import wrap
from autopilot.topics.yaw_setpoint import YawReference, YawSetpoint

YAW_STOPPED = math.radians(5.0)  # rad/s: a centred yaw stick locks the heading once the yaw rate is below this


class StickYaw:
    """The yaw stick (Position, Altitude, Orbit's RC_CONTROLLED): the stick's rate while it is out or the turn it
    made is still stopping, then the heading locked where the nose stopped. PX4's StickYaw locks once its filtered
    rate set-point is back to zero; here it locks once the body yaw rate is below YAW_STOPPED (locked at once, the
    weak hover yaw overshot a fast turn's lock by 110 deg and swung back). `heading` (rad) is the nose while
    turning, then the locked heading."""

    def __init__(self) -> None:
        self.heading = 0.0

    def reset(self, yaw: float) -> None:
        """Lock the heading at `yaw` (rad)."""
        self.heading = yaw

    def update(self, stick_rate: float, yaw: float, yaw_rate: float) -> YawSetpoint:
        """The set-point for the stick's rate (rad/s) at the nose's yaw (rad) and body yaw rate (rad/s)."""
        if stick_rate != 0.0 or abs(yaw_rate) > YAW_STOPPED:
            self.heading = yaw
            return YawSetpoint(rate=stick_rate)
        return YawSetpoint(self.heading)


def multicopter_speed(velocity_setpoint: np.ndarray, speed_max: float) -> bool:
    """The horizontal set-point is slow enough for the nose to point away from the course (a tiltrotor in forward
    flight cannot hold a yaw away from its track)."""
    return math.hypot(float(velocity_setpoint[0]), float(velocity_setpoint[1])) <= speed_max


class YawShaper:
    """The yaw set-point as a reference the controllers can follow: a heading step becomes a turn at a bounded rate,
    as PX4 limits its automatic yaw rate (MPC_YAWRAUTO_MAX)."""

    def __init__(self) -> None:
        self.reference: YawReference | None = None

    def update(self, setpoint: YawSetpoint | None, yaw_now: float, max_rate: float, dt: float) -> YawReference | None:
        """One tick of `dt` seconds; None when there is no set-point (the controllers' own rule flies the nose)."""
        if setpoint is None or (setpoint.heading is None and setpoint.rate is None):
            self.reference = None
            return None
        if setpoint.heading is None:  # a rate alone: turn from where the nose is
            self.reference = YawReference(yaw_now, float(setpoint.rate))
            return self.reference
        feed_forward = 0.0 if setpoint.rate is None else setpoint.rate
        limit = max(max_rate, abs(feed_forward)) * dt
        start = yaw_now if self.reference is None else self.reference.yaw
        start = yaw_now + wrap(start - yaw_now)
        error = wrap(setpoint.heading - start)
        if abs(error) > limit:
            step = math.copysign(limit, error)
            self.reference = YawReference(start + step, step / dt)
        else:
            self.reference = YawReference(start + error, feed_forward)
        return self.reference
