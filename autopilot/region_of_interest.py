"""The vehicle's region of interest (PX4's vehicle_roi, set by DO_SET_ROI_* items and commands): where the nose
points on a mission's legs (autopilot/auto_flight.py)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class RegionOfInterest:
    """Where the nose points: `xy` (NE, m), or the target being flown to when None (ROI_WPNEXT), turned by
    `yaw_offset` (rad)."""

    xy: np.ndarray | None
    yaw_offset: float = 0.0
