"""Mission items for GroundStation.upload_mission, placed as a test places them: metres north and east of the
vehicle's home, altitudes above home (MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, QGroundControl's "relative" frame). Any
other item is a MissionItem built directly (a MISSION_ITEM_INT without its addressing)."""

from __future__ import annotations

import math

from autopilot.topics.mission_items import MissionItem
from transport.geodesy import Home, LocalGeodetic
from transport.mavlink import mavlink as M


def _at(home: Home, north_m: float, east_m: float) -> tuple[int, int]:
    lat, lon, _ = LocalGeodetic(home).to_geodetic(north_m, east_m, 0.0)
    return round(lat * 1e7), round(lon * 1e7)


def waypoint(home: Home, north_m: float, east_m: float, altitude_m: float,
             acceptance_m: float = math.nan) -> MissionItem:  # fmt: skip
    """MAV_CMD_NAV_WAYPOINT `north_m`, `east_m` from `home`, `altitude_m` above it; `acceptance_m`: its acceptance
    radius (NaN: the vehicle's NAV_ACC_RAD)."""
    x, y = _at(home, north_m, east_m)
    return MissionItem(M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_CMD_NAV_WAYPOINT, 1, 0.0, acceptance_m, 0.0,
                       math.nan, x, y, altitude_m)  # fmt: skip


def landing(home: Home, north_m: float, east_m: float) -> MissionItem:
    """MAV_CMD_NAV_LAND `north_m`, `east_m` from `home`."""
    x, y = _at(home, north_m, east_m)
    return MissionItem(M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_CMD_NAV_LAND, 1, 0.0, 0.0, 0.0, math.nan, x, y, 0.0)
