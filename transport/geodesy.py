"""Local NED <-> geodetic conversions, exact where it matters and fast where it is called every step.

pymap3d does the geodesy (WGS-84). One pymap3d call costs ~85 us, too much at 400 Hz, so positions are
converted with pymap3d's local Jacobian around an anchor that follows the vehicle: the anchor is moved
(with an exact pymap3d call) whenever the vehicle is more than ANCHOR_RADIUS from it. Within that radius
the linearisation error is about d^2 / R_earth ~ 6 mm, below MAVLink's 1e-7 deg (~1.1 cm) resolution.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import pymap3d

ANCHOR_RADIUS = 200.0  # m


@dataclass(frozen=True)
class Home:
    """Geodetic origin of the local NED frame: latitude, longitude (deg) and altitude AMSL (m). The default is
    PX4 SITL's home (Zurich, 488 m AMSL)."""

    lat: float = 47.397742
    lon: float = 8.545594
    alt: float = 488.0


HOME_ENVIRONMENT = ("PX4_HOME_LAT", "PX4_HOME_LON", "PX4_HOME_ALT")  # read as PX4 SITL reads them


class HomeRefused(ValueError):
    """A home that cannot be one (out of range, not a number), with the reason."""


def home_from(given: tuple[float, float, float] | None, environ: Mapping[str, str]) -> Home:
    """The home of a process: `given` (a `--home` option) if there is one, else PX4's default with each of
    PX4_HOME_LAT / PX4_HOME_LON / PX4_HOME_ALT from `environ` in its place, as PX4 SITL does."""
    if given is not None:
        lat, lon, alt = given
        source = f"--home {lat},{lon},{alt}"
    else:
        default = Home()
        parts = []
        for name, fallback in zip(HOME_ENVIRONMENT, (default.lat, default.lon, default.alt), strict=True):
            text = environ.get(name, "").strip()
            try:
                parts.append(float(text) if text else fallback)
            except ValueError:
                raise HomeRefused(f"{name}={text!r} is not a number") from None
        lat, lon, alt = parts
        source = "PX4_HOME_LAT/LON/ALT"
    if not all(math.isfinite(x) for x in (lat, lon, alt)):
        raise HomeRefused(f"{source}: not finite")
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        raise HomeRefused(f"{source}: latitude/longitude out of range")
    if not -500.0 <= alt <= 10_000.0:
        raise HomeRefused(f"{source}: altitude {alt} m AMSL out of range (-500 to 10000)")
    return Home(lat, lon, alt)


class LocalGeodetic:
    """Converts NED positions (m, relative to home) to latitude, longitude (deg) and altitude (m)."""

    def __init__(self, home: Home) -> None:
        self.home = home
        self._anchor(0.0, 0.0)

    def _anchor(self, north: float, east: float) -> None:
        h = self.home
        self._n0, self._e0 = north, east
        self._lat0, self._lon0, _ = pymap3d.ned2geodetic(north, east, 0.0, h.lat, h.lon, h.alt)
        lat_n, lon_n, _ = pymap3d.ned2geodetic(north + 1.0, east, 0.0, h.lat, h.lon, h.alt)
        lat_e, lon_e, _ = pymap3d.ned2geodetic(north, east + 1.0, 0.0, h.lat, h.lon, h.alt)
        self._dlat_dn, self._dlon_dn = float(lat_n - self._lat0), float(lon_n - self._lon0)
        self._dlat_de, self._dlon_de = float(lat_e - self._lat0), float(lon_e - self._lon0)
        self._lat0, self._lon0 = float(self._lat0), float(self._lon0)

    def to_ned(self, lat: float, lon: float, alt: float) -> tuple[float, float, float]:
        """NED position (m) of a geodetic point, with the same anchored linearisation (inverse of to_geodetic)."""
        dlat, dlon = lat - self._lat0, lon - self._lon0
        det = self._dlat_dn * self._dlon_de - self._dlat_de * self._dlon_dn
        dn = (self._dlon_de * dlat - self._dlat_de * dlon) / det
        de = (self._dlat_dn * dlon - self._dlon_dn * dlat) / det
        north, east = self._n0 + dn, self._e0 + de
        if dn * dn + de * de > ANCHOR_RADIUS**2:
            self._anchor(north, east)
            return self.to_ned(lat, lon, alt)
        return north, east, self.home.alt - alt

    def to_geodetic(self, north: float, east: float, down: float) -> tuple[float, float, float]:
        """(lat deg, lon deg, alt m AMSL) of a NED position; altitude is home altitude minus down."""
        dn, de = north - self._n0, east - self._e0
        if dn * dn + de * de > ANCHOR_RADIUS**2:
            self._anchor(north, east)
            dn, de = 0.0, 0.0
        lat = self._lat0 + self._dlat_dn * dn + self._dlat_de * de
        lon = self._lon0 + self._dlon_dn * dn + self._dlon_de * de
        return lat, lon, self.home.alt - down


def ned_from_geodetic(home: Home, lat: float, lon: float, alt: float) -> tuple[float, float, float]:
    """Exact NED position (m) of a geodetic point relative to home (for set-points; not on a hot path)."""
    n, e, d = pymap3d.geodetic2ned(lat, lon, alt, home.lat, home.lon, home.alt)
    return float(n), float(e), float(d)
