"""The Offboard velocity set-point as the commander keeps it: the latest one, when it arrived (for the
COM_OF_LOSS_T failsafe), and, with `--offboard-lockstep`, the stamped ones waiting for their simulation time.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.stamped_setpoints import StampedSetpoints

SETPOINT_LIMITS = np.array([30.0, 30.0, 10.0])  # m/s: the MPC's velocity envelope; set-points are clamped to it


def in_envelope(velocity: np.ndarray, body: bool, yaw: float) -> tuple[np.ndarray, bool]:
    """A set-point in NED (rotated by the yaw when it is in a body frame), clamped to SETPOINT_LIMITS; True when
    it had to be clamped."""
    if body:
        c, s = math.cos(yaw), math.sin(yaw)
        velocity = np.array([c * velocity[0] - s * velocity[1], s * velocity[0] + c * velocity[1], velocity[2]])
    clamped = np.clip(velocity, -SETPOINT_LIMITS, SETPOINT_LIMITS)
    return clamped, not np.array_equal(clamped, velocity)


class OffboardSetpoint:
    def __init__(self, stamped: bool) -> None:
        self.velocity = np.zeros(3)  # NED, m/s
        self.received_usec: int | None = None
        self.stamped = StampedSetpoints() if stamped else None

    def receive(self, velocity_ned: np.ndarray, stamp_ms: int | None, now_usec: int) -> None:
        """A set-point received now; a stamped one (--offboard-lockstep) takes effect at its time_boot_ms."""
        if self.stamped is not None and stamp_ms is not None:
            self.stamped.add(stamp_ms, velocity_ned)
            return
        self.velocity = velocity_ned
        self.received_usec = now_usec

    def take_due(self, time_usec: int) -> None:
        """The newest stamped set-point whose time has come takes effect."""
        if self.stamped is not None and (due := self.stamped.due(time_usec)) is not None:
            self.velocity = due
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
