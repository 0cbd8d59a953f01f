"""The interface every flight mode meets (PX4's NavigatorMode), and what the modes share. The commander chooses the
mode; the active mode turns the state into a velocity set-point (NED, m/s) at 100 Hz.

    id                   the mode's name and PX4 custom mode (topics/flight_mode.py)
    needs_position       a ground station may choose it only with a position estimate
    prevents_arming      arming is refused while it is chosen (PX4's mode_req_prevent_arming)
    entry_refusal(entry) why a ground station may not choose it now (None: it may), beside the commander's own checks
    entered_from(mode)   it is being entered from `mode` (before activate)
    activate(state)      the mode is entered (or entered again) here
    setpoint(state)      the velocity set-point of this tick
    lifts_off(state)     armed on the ground, the mode asks to take off
    yaw(state)           the yaw set-point of this tick (None: the velocity controllers' own rule), after setpoint()
    landing              it is descending onto a landing point (reported as MAV_LANDED_STATE_LANDING)
    detects_landing      the commander's land detector watches for a touchdown
    touched_down(state)  the land detector saw the touchdown
    flies_mission        it is flying the stored mission's items (the region of interest applies at once)

A mode is one module in navigator/modes/, built on the ModeContext, and one row in its table (modes/__init__.py).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from autopilot.navigator.auto_flight import AutoFlight
from autopilot.navigator.flight_tasks import FlightTasks
from autopilot.navigator.manual_control import ManualControl
from autopilot.navigator.mission_feasibility import MissionFeasibility
from autopilot.navigator.mission_flight import MissionFlight
from autopilot.navigator.offboard_setpoint import OffboardSetpoint
from autopilot.navigator.target_estimator import TargetEstimator
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.flight_mode import ModeId
from autopilot.topics.home_position import HomeReader
from autopilot.topics.requests import Reply
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawSetpoint

OFFBOARD_TAKEOFF_CLIMB = 0.3  # m/s: a set-point (Offboard, the sticks) climbing faster than this lifts off


@dataclass(frozen=True)
class ModeEntry:
    """What a mode's entry rules see of the vehicle when a ground station asks for the mode."""

    now_usec: int
    flying: bool


@dataclass(frozen=True)
class ModeContext:
    """What the flight modes share, built once for the vehicle (navigator/navigator.py)."""

    params: ParameterStore
    tasks: FlightTasks  # Hold, Takeoff, Land and Offboard positions
    auto: AutoFlight  # routes of targets: Go-to, Orbit, Return
    mission: MissionFlight  # the stored mission, item by item
    feasibility: MissionFeasibility  # the mission against the geofence
    offboard: OffboardSetpoint  # the client's latest Offboard set-point
    manual: ManualControl  # the latest MANUAL_CONTROL sticks
    target: TargetEstimator  # the Follow Me target, from FOLLOW_TARGET
    homes: HomeReader
    hover_fraction: float  # the rotors' hover thrust as a fraction of their full thrust
    say: Callable[..., None]  # a STATUSTEXT: say(severity, text)


class FlightMode(ABC):
    """The interface; the defaults are those of a mode that neither takes off nor lands."""

    id: ModeId
    needs_position = True
    prevents_arming = False
    resets_land_detector = False
    restarts_when_reentered = True  # entered again while active, it starts afresh

    @property
    def landing(self) -> bool:
        return False

    @property
    def detects_landing(self) -> bool:
        return self.landing

    @property
    def flies_mission(self) -> bool:
        return False

    def entry_refusal(self, entry: ModeEntry) -> Reply | None:
        return None

    def entered_from(self, mode: FlightMode) -> None:
        pass

    def activate(self, state: VehicleState) -> None:
        pass

    @abstractmethod
    def setpoint(self, state: VehicleState) -> np.ndarray: ...

    def yaw(self, state: VehicleState) -> YawSetpoint | None:
        return None

    def lifts_off(self, state: VehicleState) -> bool:
        return False

    def touched_down(self, state: VehicleState) -> None:
        pass
