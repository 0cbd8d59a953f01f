"""Home: where Return lands and the geofence's GF_MAX_HOR_DIST / GF_MAX_VER_DIST are measured from.

The local NED frame's origin is fixed (the `--home` of both processes, PX4_HOME_LAT/LON/ALT or PX4 SITL's
default). Home is set as PX4's commander sets it (its HomePosition): where the vehicle is at the first valid
position on the ground, at every arming, and, disarmed on the ground, again when the vehicle has moved more than
1 m horizontally or 1.5 m vertically from it; never over a home a ground station gave in coordinates
(MAV_CMD_DO_SET_HOME, PX4's manual_home), which stays until the next DO_SET_HOME. A vehicle spawned in the air
has the origin (the ground under its spawn point) as home until one of these sets it. Home never moves the origin:
local positions (LOCAL_POSITION_NED, the set-points) stay relative to it. HOME_POSITION carries home's latitude,
longitude and altitude, and its x, y, z in the local frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import pymap3d

from transport.geodesy import Home, ned_from_geodetic

MIN_ALT, MAX_ALT = -500.0, 10_000.0  # m AMSL: the altitudes a home may have (as --home)
MOVED_HORIZONTAL, MOVED_VERTICAL = 1.0, 1.5  # m: PX4's kMinHomePositionChangeEPH / EPV (the estimate is exact here)


@dataclass(frozen=True)
class HomePosition:
    lat: float  # deg
    lon: float  # deg
    alt: float  # m AMSL
    north: float  # m from the local origin
    east: float
    down: float
    manual: bool = False  # set by DO_SET_HOME's coordinates (PX4's manual_home): arming leaves it

    @property
    def ned(self) -> np.ndarray:
        return np.array([self.north, self.east, self.down])


def at_origin(origin: Home) -> HomePosition:
    return HomePosition(origin.lat, origin.lon, origin.alt, 0.0, 0.0, 0.0)


def home_refusal(lat: float, lon: float, alt: float) -> str | None:
    """Why (lat, lon, alt) cannot be home, or None."""
    if not all(math.isfinite(x) for x in (lat, lon, alt)):
        return f"latitude, longitude and altitude must be finite, not {lat:g}, {lon:g}, {alt:g}"
    if abs(lat) > 90.0 or abs(lon) > 180.0:
        return f"latitude/longitude {lat:g}, {lon:g} out of range"
    if not MIN_ALT <= alt <= MAX_ALT:
        return f"altitude {alt:g} m AMSL not in {MIN_ALT:g}..{MAX_ALT:g} m"
    return None


def home_at(origin: Home, lat: float, lon: float, alt: float) -> HomePosition:
    """A home set at a geodetic point (checked with home_refusal first)."""
    north, east, down = ned_from_geodetic(origin, lat, lon, alt)
    return HomePosition(lat, lon, alt, north, east, down, manual=True)


def home_here(origin: Home, position_ned: np.ndarray) -> HomePosition:
    """A home set where the vehicle is (`position_ned` from the origin); not manual, as PX4's setHomePosition."""
    north, east, down = (float(x) for x in position_ned[0:3])
    lat, lon, alt = (float(x) for x in pymap3d.ned2geodetic(north, east, down, origin.lat, origin.lon, origin.alt))
    return HomePosition(lat, lon, alt, north, east, down)


def moved_from(home: HomePosition, position_ned: np.ndarray) -> bool:
    """The vehicle is far enough from home that a disarmed vehicle on the ground takes home with it (PX4's
    hasMovedFromCurrentHomeLocation)."""
    horizontal = math.hypot(float(position_ned[0]) - home.north, float(position_ned[1]) - home.east)
    return horizontal > MOVED_HORIZONTAL or abs(float(position_ned[2]) - home.down) > MOVED_VERTICAL


class HomeReader(Protocol):
    """Where home is, for the parts that fly to it or measure from it (the commander's HomeKeeper sets it)."""

    @property
    def origin(self) -> Home:
        """The local frame's origin (fixed)."""
        ...

    @property
    def position(self) -> HomePosition:
        """The current home (a new object is a new home)."""
        ...
