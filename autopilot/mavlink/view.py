"""What every MAVLink service works from: the latest VehicleStatus and the simulation time now."""

from __future__ import annotations

from dataclasses import dataclass

from autopilot.vehicle_status import VehicleStatus


@dataclass
class StatusView:
    status: VehicleStatus | None = None  # None until the flight stack's first snapshot
    now_usec: int = 0

    def clock(self) -> int:
        return self.now_usec
