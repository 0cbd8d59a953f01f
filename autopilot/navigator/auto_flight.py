"""Flying a route of position targets with velocity set-points (Mission, Return, Go-to, Orbit; docs/mavlink.md).

A route is a list of targets flown one after the other:

    Climb    climb over a point to an altitude (a takeoff, or Return's climb to RTL_RETURN_ALT)
    FlyTo    the leg from where the previous target ended to a position, at the leg's cruise speed, braking
             into it (in a mission's fixed-wing phase, after DO_VTOL_TRANSITION to FW: through it, and the
             set-point turns at speed); done within its acceptance radius (and 3 m of its altitude)
    HoldAt   hold a position for some seconds (None: for ever)
    LandAt   fly to a point, stop over it, descend (MPC_Z_VEL_MAX_DN, MPC_LAND_SPEED below MPC_LAND_ALT2) until
             the commander's land detector sees the touchdown
    Circle   circle a centre (Orbit) for ever, the nose as DO_ORBIT's yaw behaviour asks

The set-point is ramped at MPC_ACC_HOR (guidance.ramp) like the Offboard position set-points. The speeds are
velocity set-points only: the unified MPC flies a leg at FW_AIRSPD_TRIM in forward flight with no mode logic.
A target's yaw (rad; None: the velocity controllers' own rule) is its yaw set-point; a FlyTo with a yaw flown as a
multicopter is done only once the heading is within MIS_YAW_ERR of it (PX4's waypoint yaw check; not waited for
with a yaw timeout, MIS_YAW_TMT > 0); a HoldAt without
one holds the yaw of the last target that had one.

A region of interest (`point_at`, a mission's DO_SET_ROI_* items) replaces the targets' yaw outside the fixed-wing
phase: the nose points at it, or at the target being flown to (ROI_WPNEXT) plus an offset, and keeps its last
heading within NAV_ACC_RAD of that point (PX4's MissionBase::heading_sp_update). Takeoffs, landings (LandAt and
their approach) and orbits keep their own yaw, as PX4's heading update leaves takeoff and land items alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aircraft.frames import wrap
from autopilot.navigator.guidance import (
    TICK_S,
    circle_velocity,
    leg_cruise_speed,
    leg_velocity,
    limit_norm,
    ramp,
    turn_ramp,
    vertical_velocity,
)
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.region_of_interest import RegionOfInterest
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawSetpoint
from transport.mavlink import mavlink as M

ALTITUDE_ACCEPTANCE = 3.0  # m: a FlyTo is done within this of its altitude (and its radius horizontally)
CLIMB_DONE = 0.5  # m below the climb altitude
OVER_LANDING_POINT = 1.0  # m and m/s: over the landing point and slow: descend
CIRCLE_CONVERGENCE = 50.0  # m (at most; a quarter of the radius for small circles)


ORBIT_FRONT_TO_CENTER = M.ORBIT_YAW_BEHAVIOUR_HOLD_FRONT_TO_CIRCLE_CENTER
ORBIT_INITIAL_HEADING = M.ORBIT_YAW_BEHAVIOUR_HOLD_INITIAL_HEADING
ORBIT_TANGENT = M.ORBIT_YAW_BEHAVIOUR_HOLD_FRONT_TANGENT_TO_CIRCLE
ORBIT_RC_CONTROLLED = M.ORBIT_YAW_BEHAVIOUR_RC_CONTROLLED
ORBIT_CENTER_MIN = 1.0  # m: closer to the centre than this, the centre has no direction to face


@dataclass(frozen=True)
class Climb:
    xy: np.ndarray
    down: float
    rate: float  # m/s
    yaw: float | None = None


@dataclass(frozen=True)
class FlyTo:
    position: np.ndarray  # NED
    acceptance: float  # m
    speed: float | None = None  # None: guidance.leg_cruise_speed
    yaw: float | None = None
    approach: bool = False  # a landing's approach: its own yaw whatever the region of interest (PX4 likewise)


@dataclass(frozen=True)
class HoldAt:
    position: np.ndarray
    seconds: float | None  # None: for ever
    yaw: float | None = None  # None: the last target's yaw (if any)


@dataclass(frozen=True)
class LandAt:
    xy: np.ndarray
    yaw: float | None = None


@dataclass(frozen=True)
class Circle:
    center: np.ndarray  # NE
    down: float
    radius: float
    speed: float
    clockwise: bool
    yaw_behaviour: int = ORBIT_FRONT_TO_CENTER  # ORBIT_YAW_BEHAVIOUR
    initial_heading: float = 0.0  # rad: the heading when the orbit began (HOLD_INITIAL_HEADING)


def orbit_yaw(circle: Circle, position: np.ndarray) -> YawSetpoint | None:
    """The yaw set-point of DO_ORBIT's yaw behaviour (PX4's FlightTaskOrbit): facing the centre or along the circle,
    turning at the orbit's rate as feed-forward; the initial heading; None for UNCONTROLLED (and RC_CONTROLLED,
    which the Orbit mode flies from the yaw stick)."""
    behaviour = circle.yaw_behaviour
    if behaviour == ORBIT_INITIAL_HEADING:
        return YawSetpoint(circle.initial_heading)
    if behaviour not in (ORBIT_FRONT_TO_CENTER, ORBIT_TANGENT):
        return None
    to_center = circle.center - position[0:2]
    if float(np.hypot(*to_center)) < ORBIT_CENTER_MIN:
        return None
    direction = 1.0 if circle.clockwise else -1.0  # clockwise seen from above: the heading grows
    heading = math.atan2(float(to_center[1]), float(to_center[0]))
    if behaviour == ORBIT_TANGENT:
        heading -= direction * math.pi / 2
    return YawSetpoint(wrap(heading), direction * circle.speed / circle.radius)


Target = Climb | FlyTo | HoldAt | LandAt | Circle


def target_xy(target: Climb | FlyTo | HoldAt | LandAt) -> np.ndarray:
    """The horizontal point (NE) a target flies to or over."""
    match target:
        case FlyTo(position=position) | HoldAt(position=position):
            return position[0:2]
        case Climb(xy=xy) | LandAt(xy=xy):
            return xy


class AutoFlight:
    """The route being flown and the ramped velocity set-point."""

    def __init__(self, params: ParameterStore) -> None:
        self.params = params
        self.route: list[Target] = []
        self.index = 0
        self.velocity = np.zeros(3)
        self.leg_start = np.zeros(3)
        self.descending = False
        self.mission_speed: float | None = None  # DO_CHANGE_SPEED (None: the default cruise speeds)
        self.forward_flight: bool | None = None  # the phase DO_VTOL_TRANSITION asked for (None: by leg length)
        self.last_yaw: float | None = None  # the yaw of the last target that had one (HoldAt holds it)
        self.roi: RegionOfInterest | None = None
        self._roi_yaw: float | None = None  # the last heading to the region of interest
        self._target_since_usec = 0

    # ---- routes ------------------------------------------------------------------------------------------------
    def start(self, state: VehicleState, route: list[Target]) -> None:
        """A new route from here (the set-point starts from the vehicle's velocity), in no fixed-wing phase."""
        self.velocity = state.velocity_ned.copy()
        self.forward_flight = None
        self.last_yaw = None
        self.point_at(None)
        self.follow(state, route)

    def point_at(self, roi: RegionOfInterest | None) -> None:
        """The region of interest the nose points at from now on (None: the targets' own yaw)."""
        self.roi = roi
        self._roi_yaw = None

    def follow(self, state: VehicleState, route: list[Target]) -> None:
        """Another route, continuing the set-point; its first leg starts where the last target was."""
        self.route = list(route)
        self.index = 0
        self.leg_start = state.position_ned.copy()
        self.descending = False
        self._target_since_usec = state.time_usec

    @property
    def finished(self) -> bool:
        return self.index >= len(self.route)

    @property
    def target(self) -> Target | None:
        return None if self.finished else self.route[self.index]

    @property
    def climbing(self) -> bool:
        return isinstance(self.target, Climb)

    def yaw(self, state: VehicleState) -> YawSetpoint | None:
        """The current target's yaw set-point (after step(): the target it flies)."""
        target = self.target
        if isinstance(target, Circle):
            return orbit_yaw(target, state.position_ned)
        yaw = None if target is None else self._target_yaw(state, target)
        if yaw is None:
            return YawSetpoint(self.last_yaw) if isinstance(target, HoldAt) and self.last_yaw is not None else None
        return YawSetpoint(yaw)

    def _target_yaw(self, state: VehicleState, target: Climb | FlyTo | HoldAt | LandAt) -> float | None:
        """The target's yaw, or the heading to the region of interest where one is set (its last heading within
        NAV_ACC_RAD of it; the target's yaw until it has one)."""
        roi = self.roi
        own_yaw = isinstance(target, Climb | LandAt) or (isinstance(target, FlyTo) and target.approach)
        if roi is None or self.forward_flight or own_yaw:
            return target.yaw
        point = target_xy(target) if roi.xy is None else roi.xy
        north, east = (point - state.position_ned[0:2]).tolist()
        if math.hypot(north, east) > self.params["NAV_ACC_RAD"]:
            self._roi_yaw = wrap(math.atan2(east, north) + roi.yaw_offset)
        return target.yaw if self._roi_yaw is None else self._roi_yaw

    def _yaw_reached(self, state: VehicleState, yaw: float | None) -> bool:
        """No yaw, or the heading within MIS_YAW_ERR of it; in a mission's fixed-wing phase the nose follows the
        track, so the yaw is not waited for (PX4 ignores it in fixed-wing flight too); nor with a yaw timeout
        (MIS_YAW_TMT > 0): PX4 then waits only for a forced heading (its VTOL's alignment before a front transition,
        which is not flown here), and aborts the mission when that times out."""
        if yaw is None or self.forward_flight or self.params["MIS_YAW_TMT"] > 0.0:
            return True
        return abs(wrap(yaw - float(state.euler[2]))) <= math.radians(self.params["MIS_YAW_ERR"])

    def _next(self, state: VehicleState) -> None:
        target = self.route[self.index]
        if not isinstance(target, Circle) and target.yaw is not None:
            self.last_yaw = target.yaw
        if isinstance(target, FlyTo | HoldAt):
            self.leg_start = target.position.copy()
        else:
            self.leg_start = state.position_ned.copy()
        self.index += 1
        self._target_since_usec = state.time_usec

    # ---- 100 Hz --------------------------------------------------------------------------------------------------
    def step(self, state: VehicleState) -> np.ndarray:
        """The velocity set-point; moves on to the next target when the current one is done."""
        while not self.finished:
            wanted = self._wanted(state, self.route[self.index])
            if wanted is not None:
                turn = turn_ramp if self.forward_flight else ramp
                self.velocity = turn(self.velocity, wanted, self.params["MPC_ACC_HOR"], TICK_S)
                return self.velocity.copy()
            self._next(state)
        p = self.params
        self.velocity = ramp(self.velocity, np.zeros(3), p["MPC_ACC_HOR"], TICK_S)
        return self.velocity.copy()

    def _vertical(self, state: VehicleState, down: float, up_limit: float | None = None) -> float:
        p = self.params
        return vertical_velocity(
            float(state.position_ned[2]),
            down,
            p["MPC_Z_P"],
            p["MPC_Z_VEL_MAX_UP"] if up_limit is None else up_limit,
            p["MPC_Z_VEL_MAX_DN"],
        )

    def _to_point(self, state: VehicleState, xy: np.ndarray) -> np.ndarray:
        p = self.params
        return limit_norm(leg_velocity(state.position_ned[0:2], xy, xy, p["MPC_XY_CRUISE"], p["MPC_ACC_HOR"],
                                       p["MPC_XY_P"]), p["MPC_XY_CRUISE"])  # fmt: skip

    def _wanted(self, state: VehicleState, target: Target) -> np.ndarray | None:
        """The set-point the target asks for, or None when it is done."""
        p = self.params
        position = state.position_ned
        match target:
            case Climb(xy=xy, down=down, rate=rate):
                if float(position[2]) <= down + CLIMB_DONE:
                    return None
                return np.array([*self._to_point(state, xy), self._vertical(state, down, rate)])
            case FlyTo(position=end, acceptance=acceptance, speed=speed):
                start = self.leg_start
                offset = end - position
                if (
                    float(np.hypot(offset[0], offset[1])) <= acceptance
                    and abs(float(offset[2])) <= ALTITUDE_ACCEPTANCE
                    and self._yaw_reached(state, self._target_yaw(state, target))
                ):
                    return None
                length = float(np.hypot(*(end[0:2] - start[0:2])))
                cruise = (
                    speed
                    if speed is not None
                    else leg_cruise_speed(
                        length,
                        self.mission_speed,
                        p["MPC_XY_CRUISE"],
                        p["FW_AIRSPD_TRIM"],
                        p["MPC_ACC_HOR"],
                        self.forward_flight,
                    )
                )
                horizontal = leg_velocity(
                    position[0:2],
                    start[0:2],
                    end[0:2],
                    cruise,
                    p["MPC_ACC_HOR"],
                    p["MPC_XY_P"],
                    brake=not self.forward_flight,
                )
                return np.array([*horizontal, self._vertical(state, float(end[2]))])
            case HoldAt(position=point, seconds=seconds):
                if seconds is not None and state.time_usec - self._target_since_usec >= seconds * 1e6:
                    return None
                return np.array([*self._to_point(state, point[0:2]), self._vertical(state, float(point[2]))])
            case LandAt(xy=xy):
                horizontal = self._to_point(state, xy)
                if not self.descending:
                    over = float(np.hypot(*(xy - position[0:2]))) < OVER_LANDING_POINT
                    slow = float(np.hypot(*state.velocity_ned[0:2])) < OVER_LANDING_POINT
                    self.descending = over and slow
                    if not self.descending:
                        return np.array([*horizontal, self._vertical(state, float(self.leg_start[2]))])
                height = -float(position[2])
                rate = p["MPC_LAND_SPEED"] if height < p["MPC_LAND_ALT2"] else p["MPC_Z_VEL_MAX_DN"]
                return np.array([*horizontal, rate])
            case Circle(center=center, down=down, radius=radius, speed=speed, clockwise=clockwise):
                convergence = min(CIRCLE_CONVERGENCE, max(radius / 4.0, 2.0))
                horizontal = circle_velocity(position[0:2], center, radius, speed, clockwise, convergence)
                return np.array([*horizontal, self._vertical(state, down)])
        return None
