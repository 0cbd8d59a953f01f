"""The flight modes, one class each behind one small interface, as PX4's navigator has one NavigatorMode per mode
(docs/mavlink.md). The commander (autopilot/commander/commander.py) chooses the mode; the active mode turns the state into a
velocity set-point (NED, m/s) at 100 Hz.

    activate(state)     the mode is entered (or entered again) here
    setpoint(state)     the velocity set-point of this tick
    lifts_off(state)    armed on the ground, the mode asks to take off
    yaw(state)          the yaw set-point of this tick (None: the velocity controllers' own rule), after setpoint()
    landing             it is descending onto a landing point (reported as MAV_LANDED_STATE_LANDING)
    detects_landing     the commander's land detector watches for a touchdown
    touched_down(state) the land detector saw the touchdown

Hold, Takeoff, Land and Offboard use the position logic of navigator.py; Mission, Return, Orbit and Hold after a
DO_REPOSITION fly routes of targets (auto_flight.py, mission_flight.py).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable

import numpy as np

from autopilot.navigator.auto_flight import ORBIT_RC_CONTROLLED, AutoFlight, Circle, FlyTo, HoldAt, LandAt
from autopilot.navigator.flight_tasks import Navigator
from autopilot.navigator.mission_flight import MissionFlight
from autopilot.navigator.offboard_setpoint import OffboardSetpoint
from autopilot.navigator.return_route import (
    RTL_MISSION_LANDING,
    MissionLanding,
    climb_to_return_height,
    plan_return,
    return_destination,  # fmt: skip
)
from autopilot.navigator.yaw_shaping import StickYaw
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.mission_items import MissionItem
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawSetpoint
from transport.mavlink import mavlink

HOLD, TAKEOFF, LAND, OFFBOARD = "Hold", "Takeoff", "Land", "Offboard"
MISSION, RETURN, ORBIT = "Mission", "Return", "Orbit"
MODES = (HOLD, TAKEOFF, LAND, OFFBOARD, MISSION, RETURN, ORBIT)
REPOSITION_ACCEPTANCE = 1.0  # m: a DO_REPOSITION flies the leg to within this, then holds there
OFFBOARD_TAKEOFF_CLIMB = 0.3  # m/s: an Offboard set-point climbing faster than this lifts off from the ground
VTOL_FW, VTOL_MC = mavlink.MAV_VTOL_STATE_FW, mavlink.MAV_VTOL_STATE_MC  # 4, 3


class FlightMode(ABC):
    """The interface; the defaults are those of a mode that neither takes off nor lands."""

    name = ""

    @property
    def landing(self) -> bool:
        return False

    @property
    def detects_landing(self) -> bool:
        return self.landing

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


class HoldMode(FlightMode):
    """AUTO.LOITER: brake and hold here; circle at cruise speed after a transition to fixed wing; or fly to a
    DO_REPOSITION point and hold there."""

    name = HOLD

    def __init__(self, navigator: Navigator, auto: AutoFlight) -> None:
        self.navigator = navigator
        self.auto = auto
        self.repositioning = False  # flying self.auto's route (DO_REPOSITION)
        self.transition_target = VTOL_MC

    def activate(self, state: VehicleState) -> None:
        self.repositioning = False
        self.transition_target = VTOL_MC
        self.navigator.start_hold(state)

    def hold_at(self, xy: np.ndarray, down: float) -> None:
        """Hold this point (a takeoff ended over it)."""
        self.navigator.hold_xy = xy.copy()
        self.navigator.hold_down = down

    def reposition(self, state: VehicleState, position: np.ndarray, speed: float | None, yaw: float | None) -> None:
        """Fly to `position` and hold there; `yaw` (rad; None: the controllers' own rule) on the way and there."""
        self.repositioning = True
        self.auto.start(state, [FlyTo(position, REPOSITION_ACCEPTANCE, speed, yaw), HoldAt(position, None, yaw)])

    def transition(self, target: int, state: VehicleState) -> str | None:
        """MAV_CMD_DO_VTOL_TRANSITION in Hold: to FW circle at cruise speed, to MC brake and hover; what to say
        (None: already there)."""
        if target == self.transition_target:
            return None
        self.transition_target = target
        if target == VTOL_FW:
            self.navigator.start_fixed_wing_hold(state)
            return f"Transition to fixed wing: circling at {self.navigator.params['FW_AIRSPD_TRIM']:g} m/s"
        self.navigator.start_hold(state, down=self.navigator.hold_down)
        return "Transition to multicopter: braking to a hover"

    def setpoint(self, state: VehicleState) -> np.ndarray:
        return self.auto.step(state) if self.repositioning else self.navigator.hold(state)

    def yaw(self, state: VehicleState) -> YawSetpoint | None:
        return self.auto.yaw(state) if self.repositioning else None


class TakeoffMode(FlightMode):
    """AUTO.TAKEOFF: climb over the takeoff point to the target altitude (then the commander holds there)."""

    name = TAKEOFF

    def __init__(self, navigator: Navigator) -> None:
        self.navigator = navigator

    def start(self, state: VehicleState, target_down: float) -> None:
        self.navigator.start_takeoff(state, target_down)

    def done(self, state: VehicleState) -> bool:
        return self.navigator.takeoff_done(state)

    @property
    def end(self) -> tuple[np.ndarray, float]:
        """Where the takeoff ends: the point and altitude to hold."""
        return self.navigator.takeoff_xy, self.navigator.takeoff_down

    def lifts_off(self, state: VehicleState) -> bool:
        return True

    def setpoint(self, state: VehicleState) -> np.ndarray:
        return self.navigator.takeoff(state)


class LandMode(FlightMode):
    """AUTO.LAND: brake, descend, touch down; PX4's Descend (position lost): the same with no horizontal position
    control, only a zero horizontal velocity."""

    name = LAND

    @property
    def landing(self) -> bool:
        return True

    def __init__(self, navigator: Navigator) -> None:
        self.navigator = navigator
        self.descend = False

    def activate(self, state: VehicleState) -> None:
        self.descend = False
        self.navigator.start_land(state)

    def setpoint(self, state: VehicleState) -> np.ndarray:
        setpoint = self.navigator.land(state)
        if self.descend:
            setpoint[0:2] = 0.0
        return setpoint


class OffboardMode(FlightMode):
    """OFFBOARD: the client's velocity set-point, or the velocity that flies to its position set-point."""

    name = OFFBOARD
    @property
    def detects_landing(self) -> bool:  # a client may land the vehicle with its set-points
        return True

    def __init__(self, navigator: Navigator, offboard: OffboardSetpoint, hover_fraction: float) -> None:
        self.navigator = navigator
        self.offboard = offboard
        self.hover_fraction = hover_fraction

    def activate(self, state: VehicleState) -> None:
        self.navigator.start_tracking(state)

    def setpoint(self, state: VehicleState) -> np.ndarray:
        if self.offboard.attitude is not None:  # flown by the attitude loop: what it asks of the land detector
            return self.offboard.attitude.climb(self.hover_fraction)
        if self.offboard.position is None:
            return self.offboard.velocity
        return self.navigator.track(state, self.offboard.position, self.offboard.velocity)

    def yaw(self, state: VehicleState) -> YawSetpoint | None:
        return self.offboard.yaw  # None while an attitude set-point flies (OffboardSetpoint clears it)

    def lifts_off(self, state: VehicleState) -> bool:
        return bool(self.setpoint(state)[2] < -OFFBOARD_TAKEOFF_CLIMB)


class MissionMode(FlightMode):
    """AUTO.MISSION: the stored mission, item by item (mission_flight.py)."""

    name = MISSION

    def __init__(self, mission: MissionFlight) -> None:
        self.mission = mission

    @property
    def stored(self) -> bool:
        """A mission is stored to fly."""
        return bool(self.mission.items)

    def activate(self, state: VehicleState) -> None:
        self.mission.start(state)

    @property
    def landing(self) -> bool:
        return self.mission.landing

    def lifts_off(self, state: VehicleState) -> bool:
        return self.mission.auto.climbing

    def setpoint(self, state: VehicleState) -> np.ndarray:
        return self.mission.step(state)

    def yaw(self, state: VehicleState) -> YawSetpoint | None:
        return self.mission.auto.yaw(state)

    def touched_down(self, state: VehicleState) -> None:
        self.mission.landed(state)


class ReturnMode(FlightMode):
    """AUTO.RTL: climb to the return altitude, fly to the destination RTL_TYPE chooses, loiter there if
    RTL_LAND_DELAY asks, land (autopilot/navigator/return_route.py); or, to the mission's landing, climb and fly the mission
    from its DO_LAND_START item (mission_flight.py), or go on with it when Mission was already flying its landing
    (PX4's navigator does not switch then). It says PX4's texts as it goes."""

    name = RETURN

    def __init__(self, params: ParameterStore, auto: AutoFlight, mission: MissionFlight,
                 mission_valid: Callable[[], bool], say: Callable[..., None]) -> None:  # fmt: skip
        self.params = params
        self.auto = auto
        self.mission = mission
        self.mission_valid = mission_valid  # the stored mission passes the feasibility check
        self.say = say
        self.mission_was_flying = False  # the commander sets it: the mode Return was entered from was Mission
        self.mission_landing = False  # flying the mission's landing
        self._landing_mission: tuple[MissionItem, ...] = ()  # the mission whose landing is flown
        self._announced = -1  # the route's target last announced

    def activate(self, state: VehicleState) -> None:
        home = self.mission.homes.position
        rtl_type = self.params.get_int("RTL_TYPE")
        landing = self.mission.landing_pattern() if rtl_type == RTL_MISSION_LANDING else None
        if landing is not None and not self.mission_valid():
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


class OrbitMode(FlightMode):
    """Orbit (PX4's POSCTL.ORBIT navigation state): circle a centre for ever; the nose as the orbit's yaw behaviour
    asks, RC_CONTROLLED: turned by the yaw stick and locked where it stops, as in Position mode (`stick_yaw_rate`:
    rad/s at a simulation time, None without fresh sticks)."""

    name = ORBIT

    def __init__(self, auto: AutoFlight, stick_yaw_rate: Callable[[int], float | None]) -> None:
        self.auto = auto
        self.stick_yaw_rate = stick_yaw_rate
        self.stick_yaw = StickYaw()

    def start(self, state: VehicleState, circle: Circle) -> None:
        self.auto.start(state, [circle])
        self.stick_yaw.reset(float(state.euler[2]))

    def setpoint(self, state: VehicleState) -> np.ndarray:
        return self.auto.step(state)

    def yaw(self, state: VehicleState) -> YawSetpoint | None:
        target = self.auto.target
        if isinstance(target, Circle) and target.yaw_behaviour == ORBIT_RC_CONTROLLED:
            rate = self.stick_yaw_rate(state.time_usec)
            if rate is None:  # the nose is free until the sticks are back, and then locked where it is
                self.stick_yaw.reset(float(state.euler[2]))
                return None
            return self.stick_yaw.update(rate, float(state.euler[2]), float(state.body_rates[2]))
        return self.auto.yaw(state)
