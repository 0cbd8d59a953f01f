"""Altitude (PX4's ALTCTL): the sticks fly as in Position, but centred horizontal sticks only stop asking for a
velocity (the vehicle may drift); the altitude is held. Needs no position estimate."""

from __future__ import annotations

from autopilot.navigator.modes.sticks import StickMode
from autopilot.topics.flight_mode import PX4_MAIN_ALTCTL, ModeId

ALTITUDE = "Altitude"


class AltitudeMode(StickMode):
    """ALTCTL: the sticks as velocity set-points; a centred throttle holds the altitude, no position hold."""

    id = ModeId(ALTITUDE, PX4_MAIN_ALTCTL)
    needs_position = False
    holds_position = False
