"""Offboard set-points stamped with the simulation time they are meant for (`--offboard-lockstep`, docs/scenarios.md).

A scripted ground station that must stay in step with a lockstep simulation stamps each
SET_POSITION_TARGET_* with the vehicle's `time_boot_ms` at which it should take effect. The autopilot keeps
them in stamp order, applies each when the simulation reaches its stamp, and holds the lockstep (does not
answer the plant) while no set-point covers the current time, i.e. while the newest stamp is older than now.
So what flies depends only on the stamps, never on when the datagrams happened to arrive.

Times are compared in whole milliseconds, the resolution of `time_boot_ms`.
"""

from __future__ import annotations

import bisect

import numpy as np

from autopilot.topics.yaw_setpoint import YawSetpoint

Stamped = tuple[np.ndarray, YawSetpoint | None]  # a velocity set-point (NED, m/s) and its yaw set-point


class StampedSetpoints:
    """The set-points received and not yet due, in stamp order (equal stamps: the later one wins)."""

    def __init__(self) -> None:
        self._stamps: list[int] = []
        self._setpoints: list[Stamped] = []
        self.covered_ms = -1  # the newest stamp received: set-points cover the simulation up to here

    def add(self, stamp_ms: int, setpoint: Stamped) -> None:
        index = bisect.bisect_right(self._stamps, stamp_ms)
        self._stamps.insert(index, stamp_ms)
        self._setpoints.insert(index, setpoint)
        self.covered_ms = max(self.covered_ms, stamp_ms)

    def covers(self, time_usec: int) -> bool:
        """A set-point for this simulation time (or later) has arrived: the simulation may go on."""
        return self.covered_ms >= time_usec // 1000

    def due(self, time_usec: int) -> Stamped | None:
        """The newest set-point whose stamp has been reached (those before it are dropped), or None."""
        count = bisect.bisect_right(self._stamps, time_usec // 1000)
        if count == 0:
            return None
        setpoint = self._setpoints[count - 1]
        del self._stamps[:count], self._setpoints[:count]
        return setpoint

    def clear(self) -> None:
        self._stamps.clear()
        self._setpoints.clear()
        self.covered_ms = -1
