"""What every MAVLink service works from: the latest VehicleStatus (home and the stored missions with it) and the
simulation time now."""

from __future__ import annotations

from dataclasses import dataclass

from autopilot.topics.home_position import HomePosition
from autopilot.topics.missions import EMPTY, Missions
from autopilot.topics.vehicle_status import VehicleStatus


@dataclass
class StatusView:
    status: VehicleStatus | None = None  # None until the flight stack's first snapshot
    now_usec: int = 0
    loaded_missions: Missions = EMPTY  # the stored lists as the mission file held them at start

    @property
    def missions(self) -> Missions:
        """The stored lists as the flight stack keeps them (before its first snapshot: as loaded at start)."""
        # The first plant step reads the links (and what was sent to them during the start) before it publishes
        # the first snapshot: a download then must get the lists on disk, not none (PX4 loads its dataman before
        # its mavlink module answers).
        return self.loaded_missions if self.status is None else self.status.missions

    def clock(self) -> int:
        return self.now_usec

    @property
    def home(self) -> HomePosition | None:
        """Home as the flight stack keeps it (None before its first snapshot)."""
        return None if self.status is None else self.status.home
