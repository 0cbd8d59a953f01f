"""The flight modes, one module each (PX4's navigator has one NavigatorMode per mode), and the vehicle's table of
them: a new mode is a new module here and a row in MODES. The order is the one ground stations are told."""

from __future__ import annotations

from autopilot.navigator.mode import FlightMode, ModeContext
from autopilot.navigator.modes.altitude import AltitudeMode
from autopilot.navigator.modes.follow_target import FollowTargetMode
from autopilot.navigator.modes.hold import HoldMode
from autopilot.navigator.modes.land import LandMode
from autopilot.navigator.modes.mission import MissionMode
from autopilot.navigator.modes.offboard import OffboardMode
from autopilot.navigator.modes.orbit import OrbitMode
from autopilot.navigator.modes.position import PositionMode
from autopilot.navigator.modes.rtl import ReturnMode
from autopilot.navigator.modes.takeoff import TakeoffMode

MODES: tuple[type[FlightMode], ...] = (
    HoldMode,
    TakeoffMode,
    LandMode,
    OffboardMode,
    MissionMode,
    ReturnMode,
    FollowTargetMode,
    OrbitMode,
    PositionMode,
    AltitudeMode,
)


def build_modes(context: ModeContext, table: tuple[type[FlightMode], ...] = MODES) -> dict[str, FlightMode]:
    """The vehicle's modes by name, each built on the shared context."""
    return {mode.id.name: mode for mode in (kind(context) for kind in table)}
