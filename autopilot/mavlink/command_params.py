"""A COMMAND_LONG's or COMMAND_INT's seven parameters as the commands read them: integers, and positions in the
global frames (COMMAND_INT: latitude and longitude in degE7, the altitude in its frame's reference;
global_frames.altitude_amsl) as targets in the local frame, NED from its origin."""

from __future__ import annotations

import math

from autopilot.mavlink.global_frames import altitude_amsl
from autopilot.mavlink.view import StatusView
from transport.geodesy import Home, ned_from_geodetic

Params = tuple[float, float, float, float, float, float, float]
MIN_TARGET_HEIGHT_M = 1.0  # a go-to or orbit target lower than this above home would fly into the ground


def int_param(value: float) -> int | None:
    """A command parameter that must be an integer: its value, or None if it is not one."""
    if not math.isfinite(value) or value != int(value):
        return None
    return int(value)


def latitude_longitude(p: Params, frame: int | None) -> tuple[float, float]:
    """params 5 and 6 in degrees (frame None: COMMAND_LONG's degrees; else COMMAND_INT's degE7)."""
    return (p[4] * 1e-7, p[5] * 1e-7) if frame is not None else (p[4], p[5])


class GlobalTargets:
    """Command positions as NED targets from the local frame's `origin`, checked against the home in `view`."""

    def __init__(self, origin: Home, view: StatusView) -> None:
        self.origin = origin
        self.view = view

    def horizontal(self, p: Params, frame: int | None) -> tuple[float, float] | str:
        """params 5 and 6 (latitude, longitude) as north and east, or why not."""
        lat, lon = latitude_longitude(p, frame)
        if not (math.isfinite(lat) and math.isfinite(lon)) or abs(lat) > 90.0 or abs(lon) > 180.0:
            return f"latitude/longitude {p[4]:g}, {p[5]:g} not valid"
        north, east, _ = ned_from_geodetic(self.origin, lat, lon, self.origin.alt)
        return north, east

    def position(self, p: Params, frame: int | None) -> tuple[float, float, float | None] | str:
        """params 5-7 (latitude, longitude, altitude) as north, east and down (None: NaN altitude), or why not; NaN
        latitude or longitude is refused here (the callers treat it first)."""
        horizontal = self.horizontal(p, frame)
        if isinstance(horizontal, str):
            return horizontal
        if math.isinf(p[6]):
            return "altitude infinite"
        north, east = horizontal
        down = self.down(p[6], frame)
        if isinstance(down, str):
            return down
        return north, east, down

    def down(self, altitude: float, frame: int | None) -> float | None | str:
        """A command's altitude in `frame` as NED down, checked to be at least MIN_TARGET_HEIGHT_M above home; None
        for NaN or before the first status; why not, if not."""
        home = self.view.home
        if math.isnan(altitude) or home is None:
            return None
        amsl = altitude_amsl(frame, altitude, home.alt)
        if isinstance(amsl, str):
            return amsl
        down = self.origin.alt - amsl
        if home.down - down < MIN_TARGET_HEIGHT_M:
            return (f"altitude {home.down - down:.1f} m above home: targets stay at least {MIN_TARGET_HEIGHT_M:g} m "
                    "above it")  # fmt: skip
        return down
