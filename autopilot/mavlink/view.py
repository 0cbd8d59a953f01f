"""What every MAVLink service works from: the latest VehicleStatus (home with it) and the simulation time now."""

from __future__ import annotations

from dataclasses import dataclass

from autopilot.home_position import HomePosition
from autopilot.vehicle_status import VehicleStatus


@dataclass
class StatusView:
    status: VehicleStatus | None = None  # None until the flight stack's first snapshot
    now_usec: int = 0

    def clock(self) -> int:
        return self.now_usec

    @property
    def home(self) -> HomePosition | None:
        """Home as the flight stack keeps it (None before its first snapshot)."""
        return None if self.status is None else self.status.home
