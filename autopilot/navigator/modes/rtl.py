"""Return (PX4's AUTO.RTL): climb to the return altitude, fly to the destination RTL_TYPE chooses, loiter there if
RTL_LAND_DELAY asks, land (navigator/return_route.py); or, to the mission's landing, climb and fly the mission from
its DO_LAND_START item (navigator/mission_flight.py), or go on with it when Mission was already flying its landing
(PX4's navigator does not switch then). Chosen only in flight."""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigator.auto_flight import HoldAt, LandAt
from autopilot.navigator.mode import FlightMode, ModeContext, ModeEntry
from autopilot.navigator.return_route import (
    RTL_MISSION_LANDING,
    MissionLanding,
    climb_to_return_height,
    plan_return,
    return_destination,  # fmt: skip
)
from autopilot.topics.flight_mode import PX4_AUTO_RTL, PX4_MAIN_AUTO, ModeId
from autopilot.topics.mission_items import MissionItem
from autopilot.topics.requests import Reply
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawSetpoint
from transport.mavlink import mavlink

RETURN = "Return"


class ReturnMode(FlightMode):
    """AUTO.RTL: climb to the return altitude, fly to home (or a rally point, or the mission's landing) and land,
    announced with PX4's texts as it goes."""

    id = ModeId(RETURN, PX4_MAIN_AUTO, PX4_AUTO_RTL)

    def __init__(self, context: ModeContext) -> None:
        self.params = context.params
        self.auto = context.auto
        self.mission = context.mission
        self.feasibility = context.feasibility
        self.say = context.say
        self.mission_was_flying = False  # the mode Return was entered from was flying the mission
        self.mission_landing = False  # flying the mission's landing
        self._landing_mission: tuple[MissionItem, ...] = ()  # the mission whose landing is flown
        self._announced = -1  # the route's target last announced

    def entry_refusal(self, entry: ModeEntry) -> Reply | None:
        return None if entry.flying else (mavlink.MAV_RESULT_TEMPORARILY_REJECTED, "Return denied: not flying")

    def entered_from(self, mode: FlightMode) -> None:
        self.mission_was_flying = mode.flies_mission

    @property
    def flies_mission(self) -> bool:
        return self.mission_landing

    def activate(self, state: VehicleState) -> None:
        home = self.mission.homes.position
        rtl_type = self.params.get_int("RTL_TYPE")
        landing = self.mission.landing_pattern() if rtl_type == RTL_MISSION_LANDING else None
        if landing is not None and self.feasibility.check() is not None:
            landing = None  # PX4 lands on a mission only if it is valid
        self._announced = -1
        self._landing_mission = self.mission.items
        if landing is not None and self.mission_was_flying and self.mission.landing_underway(landing):
            self.mission_landing = True  # the mission goes on landing, as it was
            self.say(mavlink.MAV_SEVERITY_INFO, "RTL: continuing the mission landing")
            return
        destination = return_destination(rtl_type, state.position_ned, self.mission.rally_points(), home.ned,
                                         landing)  # fmt: skip
        self.mission_landing = isinstance(destination, MissionLanding)
        if isinstance(destination, MissionLanding):
            height, climb = climb_to_return_height(self.params, state, destination.point, home.ned)
            self.mission.fly_landing(state, destination, climb)
            where = "mission landing"
        else:
            plan = plan_return(self.params, state, destination, home.ned)
            height = plan.height
            self.auto.start(state, plan.route)
            where = "destination"
        self.say(mavlink.MAV_SEVERITY_INFO, f"RTL: start return at {math.ceil(home.alt + height)} m "
                 f"({math.ceil(height)} m above {where})")  # fmt: skip

    @property
    def landing(self) -> bool:
        return self.auto.descending

    def setpoint(self, state: VehicleState) -> np.ndarray:
        if self.mission_landing and (self.mission.items is not self._landing_mission or self.mission.changed_elsewhere):
            self.mission_was_flying = False
            self.activate(state)  # the mission changed under its landing: Return plans again
        if self.mission_landing:
            return self.mission.step(state)
        setpoint = self.auto.step(state)
        if self.auto.index != self._announced:
            self._announced = self.auto.index
            target = self.auto.target
            if isinstance(target, HoldAt) and target.seconds is None:
                self.say(mavlink.MAV_SEVERITY_INFO, "RTL: completed, loitering")
            elif isinstance(target, LandAt):
                self.say(mavlink.MAV_SEVERITY_INFO, "RTL: land at destination")
        return setpoint

    def yaw(self, state: VehicleState) -> YawSetpoint | None:
        """A mission landing's items' yaw (and the region of interest); Return's own route has none."""
        return self.auto.yaw(state)

    def touched_down(self, state: VehicleState) -> None:
        if self.mission_landing:
            self.mission.landed(state)
