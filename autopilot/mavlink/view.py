"""What every MAVLink service works from: the latest VehicleStatus, home and the simulation time now."""

from __future__ import annotations

from dataclasses import dataclass

from autopilot.home_position import HomePosition
from autopilot.vehicle_status import VehicleStatus


@dataclass
class StatusView:
    home: HomePosition  # as the flight stack accepted it last (MAV_CMD_DO_SET_HOME): HOME_POSITION says it
    status: VehicleStatus | None = None  # None until the flight stack's first snapshot
    now_usec: int = 0

    def clock(self) -> int:
        return self.now_usec
