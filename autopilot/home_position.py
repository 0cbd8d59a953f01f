"""Home: where Return lands and the geofence's GF_MAX_HOR_DIST / GF_MAX_VER_DIST are measured from.

At start home is the origin of the local NED frame (the `--home` of both processes, PX4_HOME_LAT/LON/ALT or PX4
SITL's default). MAV_CMD_DO_SET_HOME moves home, never the origin: as in PX4, home and the local frame's reference
are two things, and local positions (LOCAL_POSITION_NED, the set-points) stay relative to the origin. HOME_POSITION
carries home's latitude, longitude and altitude, and its x, y, z in the local frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymap3d

from transport.geodesy import Home, ned_from_geodetic

MIN_ALT, MAX_ALT = -500.0, 10_000.0  # m AMSL: the altitudes a home may have (as --home)


@dataclass(frozen=True)
class HomePosition:
    lat: float  # deg
    lon: float  # deg
    alt: float  # m AMSL
    north: float  # m from the local origin
    east: float
    down: float
    manual: bool = False  # set by DO_SET_HOME (PX4's manual_home)

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
    """A home set where the vehicle is (`position_ned` from the origin)."""
    north, east, down = (float(x) for x in position_ned[0:3])
    lat, lon, alt = (float(x) for x in pymap3d.ned2geodetic(north, east, down, origin.lat, origin.lon, origin.alt))
    return HomePosition(lat, lon, alt, north, east, down, manual=True)


class HomeKeeper:
    """The local frame's origin (fixed) and the current home, shared by the commander and the parts that fly to
    or measure from home (the commander alone sets it)."""

    def __init__(self, origin: Home) -> None:
        self.origin = origin
        self.position = at_origin(origin)
