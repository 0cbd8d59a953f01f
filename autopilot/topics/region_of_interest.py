"""The vehicle's region of interest (PX4's vehicle_roi, set by DO_SET_ROI_* items and commands): where the nose
points on a mission's legs (autopilot/navigator/auto_flight.py)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from transport.mavlink import mavlink as M

ROI_MODE_OF_COMMAND = {M.MAV_CMD_DO_SET_ROI_LOCATION: M.MAV_ROI_LOCATION,
                       M.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET: M.MAV_ROI_WPNEXT,
                       M.MAV_CMD_DO_SET_ROI_NONE: M.MAV_ROI_NONE}  # fmt: skip


@dataclass(frozen=True, eq=False)
class RegionOfInterest:
    """Where the nose points: `xy` (NE, m), or the target being flown to when None (ROI_WPNEXT), turned by
    `yaw_offset` (rad)."""

    xy: np.ndarray | None
    yaw_offset: float = 0.0


def roi_mode(command: int, param1: float) -> float:
    """The MAV_ROI mode a DO_SET_ROI_* command or mission item asks for: its command's, or DO_SET_ROI's param1."""
    return ROI_MODE_OF_COMMAND.get(command, param1)


def wpnext_offset_deg(command: int, param7: float) -> float:
    """The yaw offset (deg) of an ROI_WPNEXT: DO_SET_ROI_WPNEXT_OFFSET's param7; none for DO_SET_ROI."""
    return param7 if command == M.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET else 0.0
