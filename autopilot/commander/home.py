"""Home as PX4's commander sets it (its HomePosition): at the first valid position, at arming, following a
disarmed vehicle moved on the ground, or where DO_SET_HOME puts it."""

from __future__ import annotations

import numpy as np

from autopilot.topics.home_position import HomePosition, at_origin, home_here, moved_from
from transport.geodesy import Home


class HomeKeeper:
    """The local frame's origin (fixed) and the current home, shared by the commander and the parts that fly to
    or measure from home (the commander alone sets it). `position` is replaced, never changed: a new object is a
    new home."""

    def __init__(self, origin: Home) -> None:
        self.origin = origin
        self.position = at_origin(origin)

    def set_here(self, position_ned: np.ndarray) -> bool:
        """Home where the vehicle is, unless a ground station set it in coordinates (arming, the first valid
        position); True if it was set."""
        if self.position.manual:
            return False
        self.position = home_here(self.origin, position_ned)
        return True

    def follow(self, position_ned: np.ndarray) -> bool:
        """Disarmed on the ground: home follows a vehicle that was moved (not over a manual home)."""
        return moved_from(self.position, position_ned) and self.set_here(position_ned)

    def set(self, home: HomePosition) -> None:
        """A home given in coordinates (DO_SET_HOME)."""
        self.position = home
