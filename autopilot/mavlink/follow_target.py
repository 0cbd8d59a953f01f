"""FOLLOW_TARGET (Follow Me's target: QGroundControl on a phone, MAVSDK's follow_me) to a typed request, as PX4's
MAVLink receiver takes it: lat, lon (degE7) and alt (m AMSL) as the target's position, vel (m/s, NED) as its
velocity when all three are finite (MAVSDK sends NaN for an unknown velocity); the other fields are not used, as
PX4 does not use them. The message has no target system: every one heard is the target's, as in PX4.

A position off the Earth or an altitude that is not finite (PX4 could not fuse it), or an infinite velocity, is
dropped with a STATUSTEXT saying why, at most once a while."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from autopilot.mavlink.router import GroundLink
from autopilot.mavlink.statustext import Announcer
from autopilot.mavlink.view import StatusView
from autopilot.topics.requests import FollowTargetReport, RequestHandler
from transport.geodesy import Home, ned_from_geodetic
from transport.mavlink import mavlink as M


def follow_target_refusal(lat: float, lon: float, alt: float, velocity: tuple[float, float, float]) -> str | None:
    """Why a FOLLOW_TARGET (lat, lon in degrees) cannot be taken, or None."""
    if not (math.isfinite(lat) and math.isfinite(lon) and -90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        return "position not a place on Earth"
    if not math.isfinite(alt):
        return "altitude not finite"
    if any(math.isinf(v) for v in velocity):
        return "velocity infinite"
    return None


def target_velocity(velocity: tuple[float, float, float]) -> np.ndarray | None:
    """The velocity when all three components are known (finite), else None."""
    return np.array(velocity, dtype=float) if all(math.isfinite(v) for v in velocity) else None


class FollowTargetService:
    def __init__(self, flight_stack: RequestHandler, view: StatusView, announcer: Announcer, *, origin: Home) -> None:
        self.flight_stack = flight_stack
        self.view = view
        self.announcer = announcer
        self.origin = origin  # of the local frame
        self.dropped = 0

    def on_follow_target(self, link: GroundLink, message: Any) -> None:
        lat, lon, alt = message.lat * 1e-7, message.lon * 1e-7, float(message.alt)
        velocity = (float(message.vel[0]), float(message.vel[1]), float(message.vel[2]))
        why = follow_target_refusal(lat, lon, alt, velocity)
        if why is None and self.view.home is None:
            why = "no vehicle state from the plant yet"
        if why is not None:
            self.dropped += 1
            self.announcer.say(M.MAV_SEVERITY_WARNING, f"FOLLOW_TARGET dropped: {why}", key=f"follow target:{why}")
            return
        position = np.array(ned_from_geodetic(self.origin, lat, lon, alt))
        self.flight_stack.handle(FollowTargetReport(position, target_velocity(velocity)))
