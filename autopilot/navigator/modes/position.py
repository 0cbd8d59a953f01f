"""Position (PX4's POSCTL): the sticks fly the horizontal velocity and the climb; centred, the vehicle brakes and
holds its position and altitude (navigator/modes/sticks.py)."""

from __future__ import annotations

from autopilot.navigator.modes.sticks import StickMode
from autopilot.topics.flight_mode import PX4_MAIN_POSCTL, ModeId

POSITION = "Position"


class PositionMode(StickMode):
    """POSCTL: the sticks as velocity set-points; centred, the vehicle brakes and holds its position and altitude."""

    id = ModeId(POSITION, PX4_MAIN_POSCTL)
