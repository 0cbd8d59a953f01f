"""The geofence as PX4's navigator checks it (docs/failsafes.md, "Geofence"): the uploaded fence items (inclusion and
exclusion polygons and circles) and the distances from home GF_MAX_HOR_DIST and GF_MAX_VER_DIST. Pure functions on
NED positions from home (m), no state.

A position is inside the fence when it is inside at least one inclusion zone (if there are any) and outside every
exclusion zone (PX4's rule); zones are horizontal, their altitude is GF_MAX_VER_DIST's business. A polygon is as many
consecutive vertex items of one kind as its first vertex's param1 says; a circle is one item, radius param1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from autopilot.navigator.guidance import ORIGIN_NED
from autopilot.topics.mission_items import FENCE_CIRCLES, FENCE_POLYGONS, MissionItem
from transport.geodesy import Home, ned_from_geodetic
from transport.mavlink import mavlink as M

INCLUSIONS = frozenset({M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, M.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION})


@dataclass(frozen=True)
class Polygon:
    vertices: tuple[tuple[float, float], ...]  # (north, east) m from home
    inclusion: bool


@dataclass(frozen=True)
class CircleZone:
    center: tuple[float, float]  # (north, east) m from home
    radius: float
    inclusion: bool


Zone = Polygon | CircleZone


@dataclass(frozen=True)
class Fence:
    zones: tuple[Zone, ...]
    ignored: tuple[str, ...]  # why items were not made into zones (a polygon without all its vertices)


def _north_east(home: Home, item: MissionItem) -> tuple[float, float]:
    north, east, _ = ned_from_geodetic(home, item.latitude_deg, item.longitude_deg, home.alt)
    return float(north), float(east)


def fence_from_items(items: tuple[MissionItem, ...], home: Home) -> Fence:
    """The zones of an uploaded fence (MAV_MISSION_TYPE_FENCE items, already checked one by one)."""
    zones: list[Zone] = []
    ignored: list[str] = []
    index = 0
    while index < len(items):
        item = items[index]
        inclusion = item.command in INCLUSIONS
        if item.command in FENCE_CIRCLES:
            zones.append(CircleZone(_north_east(home, item), float(item.param1), inclusion))
            index += 1
            continue
        if item.command not in FENCE_POLYGONS:
            ignored.append(f"fence item {index}: command {item.command} is not a fence zone")
            index += 1
            continue
        count = int(item.param1)
        group = items[index : index + count]
        if len(group) < count or any(vertex.command != item.command for vertex in group):
            ignored.append(f"fence item {index}: a polygon of {count} vertices without all of them")
            index += 1
            continue
        zones.append(Polygon(tuple(_north_east(home, vertex) for vertex in group), inclusion))
        index += count
    return Fence(tuple(zones), tuple(ignored))


def inside_polygon(north: float, east: float, vertices: tuple[tuple[float, float], ...]) -> bool:
    """Even-odd rule: a ray from the point towards +east crosses the edges an odd number of times."""
    inside = False
    count = len(vertices)
    for i in range(count):
        (n1, e1), (n2, e2) = vertices[i], vertices[(i + 1) % count]
        if (n1 > north) != (n2 > north):
            crossing = e1 + (north - n1) * (e2 - e1) / (n2 - n1)
            if east < crossing:
                inside = not inside
    return inside


def inside_zone(north: float, east: float, zone: Zone) -> bool:
    if isinstance(zone, CircleZone):
        return math.hypot(north - zone.center[0], east - zone.center[1]) <= zone.radius
    return inside_polygon(north, east, zone.vertices)


def breach(position_ned: np.ndarray, fence: Fence, max_horizontal: float, max_vertical: float,
           home_ned: np.ndarray = ORIGIN_NED) -> str | None:  # fmt: skip
    """Why `position_ned` is outside the geofence, or None when it is inside (0 disables a distance; the distances
    are from home, `home_ned`)."""
    north, east, down = (float(x) for x in position_ned[0:3])
    distance = math.hypot(north - float(home_ned[0]), east - float(home_ned[1]))
    height = float(home_ned[2]) - down
    if max_horizontal > 0 and distance > max_horizontal:
        return f"{distance:.0f} m from home, beyond GF_MAX_HOR_DIST {max_horizontal:g} m"
    if max_vertical > 0 and height > max_vertical:
        return f"{height:.0f} m above home, beyond GF_MAX_VER_DIST {max_vertical:g} m"
    inclusions = [zone for zone in fence.zones if zone.inclusion]
    if inclusions and not any(inside_zone(north, east, zone) for zone in inclusions):
        return "outside every inclusion zone"
    for number, zone in enumerate(fence.zones):
        if not zone.inclusion and inside_zone(north, east, zone):
            return f"inside exclusion zone {number + 1}"
    return None
