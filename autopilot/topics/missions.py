"""The stored mission, geofence and rally points with the mission's progress, as one immutable snapshot: what the
VehicleStatus carries, the navigator flies and the mission protocol serves (autopilot/storage/mission_store.py keeps
it)."""

from __future__ import annotations

from dataclasses import dataclass

from autopilot.topics.mission_items import FENCE, RALLY, MissionItem
from transport.mavlink import mavlink as M


@dataclass(frozen=True, slots=True)
class Missions:
    mission: tuple[MissionItem, ...] = ()
    fence: tuple[MissionItem, ...] = ()
    rally: tuple[MissionItem, ...] = ()
    current: int = 0  # the mission item flown next (or being flown)
    state: int = M.MISSION_STATE_NO_MISSION  # MISSION_STATE
    reached: int = -1  # the last item reached (-1: none since the mission was stored)
    reached_count: int = 0  # counts MISSION_ITEM_REACHED events (the same item can be reached twice: DO_JUMP)

    def items(self, mission_type: int) -> tuple[MissionItem, ...]:
        if mission_type == FENCE:
            return self.fence
        if mission_type == RALLY:
            return self.rally
        return self.mission


EMPTY = Missions()
