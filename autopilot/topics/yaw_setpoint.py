"""Yaw set-points (docs/mavlink.md, Yaw): what a flight mode asks of the nose, and the reference the velocity
controllers follow (navigator/yaw_shaping.py shapes the one into the other).

    YawSetpoint    heading (rad, NED) and/or rate (rad/s), as PX4's trajectory set-point carries yaw and yawspeed
    YawReference   the shaped reference: a yaw now (within pi of the nose) turning at a rate
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class YawSetpoint:
    """A heading (rad, NED) and/or a turn rate (rad/s); with both, the rate is the heading's feed-forward."""

    heading: float | None = None
    rate: float | None = None


@dataclass(frozen=True)
class YawReference:
    """The yaw the velocity controllers follow: `yaw` (rad, within pi of the nose) now, turning at `rate` (rad/s)."""

    yaw: float
    rate: float

    def at(self, seconds: float | np.ndarray) -> float | np.ndarray:
        """The reference `seconds` ahead (the MPC's stages: an array of them)."""
        return self.yaw + self.rate * seconds
