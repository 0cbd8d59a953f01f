"""PX4's navigator: the vehicle's flight modes (navigator/modes/, built on what they share) and the commands that steer
them beside the mode choice: Go-to (DO_REPOSITION), a turn in Hold, Orbit, a VTOL transition in Hold, the cruise
speed (DO_CHANGE_SPEED) and the region of interest (DO_SET_ROI_*). The commander chooses the mode and judges the
commands against its state (commander/guided_requests.py); the navigator carries them out."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

import numpy as np

from autopilot.navigator.auto_flight import AutoFlight, Circle
from autopilot.navigator.flight_tasks import FlightTasks
from autopilot.navigator.manual_control import ManualControl
from autopilot.navigator.mission_feasibility import MissionFeasibility
from autopilot.navigator.mission_flight import MissionFlight
from autopilot.navigator.mode import FlightMode, ModeContext
from autopilot.navigator.modes import MODES, build_modes
from autopilot.navigator.modes.hold import HOLD, HoldMode
from autopilot.navigator.modes.land import LAND, LandMode
from autopilot.navigator.modes.mission import MISSION, MissionMode
from autopilot.navigator.modes.orbit import ORBIT, OrbitMode
from autopilot.navigator.modes.rtl import RETURN, ReturnMode
from autopilot.navigator.modes.takeoff import TAKEOFF, TakeoffMode
from autopilot.navigator.offboard_setpoint import OffboardSetpoint
from autopilot.navigator.target_estimator import TargetEstimator
from autopilot.storage.mission_store import MissionStore
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.flight_mode import ModeId
from autopilot.topics.home_position import HomeReader
from autopilot.topics.region_of_interest import RegionOfInterest
from autopilot.topics.vehicle_state import VehicleState

Mode = TypeVar("Mode", bound=FlightMode)


class Navigator:
    """The modes of `table`, built on one ModeContext; the ones the commander and the guided commands drive by name
    (hold, takeoff, land, mission, rtl, orbit) typed."""

    def __init__(self, context: ModeContext, table: tuple[type[FlightMode], ...] = MODES) -> None:
        self.context = context
        self.modes = build_modes(context, table)
        self.hold = self._mode(HOLD, HoldMode)
        self.takeoff = self._mode(TAKEOFF, TakeoffMode)
        self.land = self._mode(LAND, LandMode)
        self.mission = self._mode(MISSION, MissionMode)
        self.rtl = self._mode(RETURN, ReturnMode)
        self.orbit = self._mode(ORBIT, OrbitMode)

    def _mode(self, name: str, kind: type[Mode]) -> Mode:
        mode = self.modes[name]
        if not isinstance(mode, kind):
            raise TypeError(f"the mode table's {name} is a {type(mode).__name__}, not a {kind.__name__}")
        return mode

    @property
    def ids(self) -> tuple[ModeId, ...]:
        """The vehicle's modes as ground stations know them, in the table's order."""
        return tuple(mode.id for mode in self.modes.values())

    def reposition(self, state: VehicleState, position: np.ndarray, speed: float | None, yaw: float | None) -> None:
        """Hold flies to `position` and holds there (Hold must be active)."""
        self.hold.reposition(state, position, speed, yaw)

    def orbit_around(self, state: VehicleState, circle: Circle) -> None:
        """Orbit circles `circle` (Orbit must be active)."""
        self.orbit.start(state, circle)

    def transition(self, target: int, state: VehicleState) -> str | None:
        """A VTOL transition in Hold; what to say (None: already there)."""
        return self.hold.transition(target, state)

    def set_cruise_speed(self, speed: float | None) -> None:
        """DO_CHANGE_SPEED: the cruise speed of Mission's, Return's and Go-to's legs (None: the defaults)."""
        self.context.auto.mission_speed = speed

    def point_at(self, roi: RegionOfInterest | None, turn_now: bool) -> None:
        """The vehicle's region of interest, which the mission keeps (turned to at once when `turn_now`)."""
        self.context.mission.point_at(roi, turn_now)


def build_navigator(params: ParameterStore, missions: MissionStore, homes: HomeReader, hover_fraction: float,
                    outside_fence: Callable[[np.ndarray], str | None], landed: Callable[[], bool],
                    say: Callable[..., None], stamped_setpoints: bool = False) -> Navigator:  # fmt: skip
    """The navigator and what its modes share: the flight tasks, the route flier, the mission, its feasibility
    against the fence (`outside_fence`: why a NED position is outside, None inside), the Offboard set-point (stamped:
    `--offboard-lockstep`), the sticks and the Follow Me target; `landed`: the vehicle is on the ground."""
    auto = AutoFlight(params)
    mission = MissionFlight(params, missions, homes, auto, landed=landed)
    context = ModeContext(params=params, tasks=FlightTasks(params), auto=auto, mission=mission,
                          feasibility=MissionFeasibility(mission, outside_fence, say),
                          offboard=OffboardSetpoint(stamped=stamped_setpoints), manual=ManualControl(params),
                          target=TargetEstimator(params), homes=homes, hover_fraction=hover_fraction,
                          say=say)  # fmt: skip
    return Navigator(context)
