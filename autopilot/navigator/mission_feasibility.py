"""The mission against the geofence, as PX4's MissionFeasibilityChecker checks it (checkGeofence): every item with
a position to fly to must be inside the stored fence and within GF_MAX_HOR_DIST / GF_MAX_VER_DIST of home. PX4 accepts the
upload (MISSION_ACK ACCEPTED) and keeps the mission as sent, says "Geofence violation for waypoint N" (N counted
from 1), and refuses to start it: MAV_CMD_MISSION_START is DENIED ("Mission start denied! No valid mission"), a
switch to Mission TEMPORARILY_REJECTED ("Switching to Mission is currently not available").

Items whose latitude and longitude are 0 fly where the vehicle is when they start (mission_flight.py): they have no
position to check, as PX4 has none for them before the flight.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from autopilot.navigator.mission_flight import MissionFlight
from autopilot.topics.mission_items import NAVIGATION, MissionItem
from transport.mavlink import mavlink


def geofence_violation(items: tuple[MissionItem, ...], position_of: Callable[[MissionItem], np.ndarray | None],
                       outside: Callable[[np.ndarray], str | None]) -> str | None:  # fmt: skip
    """PX4's text for the first item outside the fence (`outside`: why a NED position is), or None."""
    for seq, item in enumerate(items):
        if item.command not in NAVIGATION:  # a region of interest's position is not flown to (as PX4)
            continue
        position = position_of(item)
        if position is not None and outside(position) is not None:
            return f"Geofence violation for waypoint {seq + 1}"
    return None


class MissionFeasibility:
    """The stored mission (`mission`) against the fence (`outside`), saying PX4's text when it fails."""

    def __init__(self, mission: MissionFlight, outside: Callable[[np.ndarray], str | None],
                 say: Callable[..., None]) -> None:  # fmt: skip
        self.mission = mission
        self.outside = outside
        self.say = say

    def check(self) -> str | None:
        """PX4's text for the first item outside the fence (also said, as a critical STATUSTEXT), or None."""
        violation = geofence_violation(self.mission.items, self.mission.item_position, self.outside)
        if violation is not None:
            self.say(mavlink.MAV_SEVERITY_CRITICAL, violation)
        return violation
