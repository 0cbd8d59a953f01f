"""Follow Me's position logic (PX4's FlightTaskAutoFollowTarget): where the vehicle flies relative to the target
estimate (navigator/target_estimator.py), at 100 Hz in simulation time.

    target     the estimate smoothed by a second-order filter (1 rad/s, damping 0.71) that takes the estimate's
               velocity as its rate, so a target at constant speed is followed without lag
    course     the target's direction of travel, updated while it moves at 1 m/s or more
    orbit      the vehicle's angle around the target moves to course + FLW_TGT_FA (0 in front, clockwise), at most
               FLW_TGT_MAX_VEL along the circle of FLW_TGT_DST, accelerating at 2 m/s^2
    position   the target plus FLW_TGT_DST in the orbit's direction, FLW_TGT_HT above home (FLW_TGT_ALT_M 0 and 1:
               the ground is flat here) or above the target (2); flown with the target's velocity plus the
               orbit's as feed-forward
    altitude   more than 3 m off the follow altitude, the vehicle climbs (or descends) where it is first
    ascent     below 1 m above home it rises at 0.5 m/s and no more
    yaw        the nose points at the target (from more than 1 m away)

Unlike PX4, the orbit and the course start from where the vehicle is seen from the target (PX4 starts them north),
so a vehicle entering Follow Me at FLW_TGT_FA 180 closes in straight, and the orbit is acceleration-limited
(PX4's is jerk-limited as well).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aircraft.frames import wrap
from autopilot.navigator.target_estimator import TargetEstimate
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.vehicle_state import VehicleState

FILTER_FREQUENCY = 1.0  # rad/s, PX4's TARGET_POS_VEL_FILTER_NATURAL_FREQUENCY
FILTER_DAMPING = 0.7071  # PX4's TARGET_POS_VEL_FILTER_DAMPING_RATIO
COURSE_MIN_SPEED = 1.0  # m/s, PX4's TARGET_SPEED_DEADZONE_FOR_ORIENTATION_TRACKING
ORBIT_ACCELERATION = 2.0  # m/s^2 along the circle, PX4's ORBIT_TRAJECTORY_MAX_ACCELERATION
ALTITUDE_ACCEPTANCE = 3.0  # m, PX4's ALT_ACCEPTANCE_THRESHOLD
YAW_MIN_DISTANCE = 1.0  # m, PX4's MINIMUM_DISTANCE_TO_TARGET_FOR_YAW_CONTROL
SAFETY_HEIGHT = 1.0  # m above home, PX4's MINIMUM_SAFETY_ALTITUDE
ASCENT_SPEED = 0.5  # m/s, PX4's EMERGENCY_ASCENT_SPEED
ALT_MODE_TARGET = 2  # FLW_TGT_ALT_M: above the target's altitude


def filter_step(position: np.ndarray, rate: np.ndarray, sample: np.ndarray, sample_rate: np.ndarray,
                dt: float) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """One step of the second-order reference model towards `sample` with `sample_rate` as the rate's reference."""
    acceleration = FILTER_FREQUENCY**2 * (sample - position) + 2.0 * FILTER_DAMPING * FILTER_FREQUENCY * (
        sample_rate - rate
    )
    rate = rate + acceleration * dt
    return position + rate * dt, rate


def orbit_step(angle: float, rate: float, goal: float, max_rate: float, max_acceleration: float,
               dt: float) -> tuple[float, float]:  # fmt: skip
    """The orbit angle (rad) and its rate (rad/s) one step on towards `goal` the short way round: at most `max_rate`,
    changing the rate by at most `max_acceleration` per second, and slowing so as to stop at the goal."""
    remaining = wrap(goal - angle)
    wanted = math.copysign(min(max_rate, math.sqrt(2.0 * max_acceleration * abs(remaining))), remaining)
    change = max_acceleration * dt
    rate = min(max(wanted, rate - change), rate + change)
    if abs(rate * dt) >= abs(remaining) and rate * remaining >= 0.0:
        return wrap(goal), 0.0
    return wrap(angle + rate * dt), rate


def updated_course(course: float, filtered_velocity: np.ndarray, estimated_velocity: np.ndarray) -> float:
    """The target's course (rad), kept while the filtered or the estimated speed is below COURSE_MIN_SPEED."""
    if min(math.hypot(*filtered_velocity[0:2]), math.hypot(*estimated_velocity[0:2])) >= COURSE_MIN_SPEED:
        return math.atan2(float(filtered_velocity[1]), float(filtered_velocity[0]))
    return course


def bearing(origin: np.ndarray, to: np.ndarray) -> float:
    """The direction (rad, NED) from `origin` to `to`, horizontally."""
    return math.atan2(float(to[1] - origin[1]), float(to[0] - origin[0]))


@dataclass(frozen=True)
class FollowSetpoint:
    """Where to fly this tick: a position (NED) with a velocity feed-forward, or (`ascend`) straight up."""

    position: np.ndarray
    feed_forward: np.ndarray
    ascend: bool = False


class TargetFollower:
    """The filtered target, the course and the orbit, started anew each time Follow Me is entered."""

    def __init__(self, params: ParameterStore) -> None:
        self.params = params
        self.home_down = 0.0
        self.target: np.ndarray | None = None  # the filtered target (None until the first estimate)
        self.target_velocity = np.zeros(3)
        self.course = 0.0
        self.orbit = 0.0
        self.orbit_rate = 0.0
        self.heading = 0.0  # rad: the yaw set-point

    def start(self, state: VehicleState, home_down: float) -> None:
        """Follow Me entered here; home is at `home_down` (m, NED)."""
        self.home_down = home_down
        self.target = None
        self.orbit_rate = 0.0
        self.heading = float(state.euler[2])

    def _follow_down(self) -> float:
        height = self.params["FLW_TGT_HT"]
        if self.params.get_int("FLW_TGT_ALT_M") == ALT_MODE_TARGET and self.target is not None:
            return float(self.target[2]) - height
        return self.home_down - height

    def update(self, state: VehicleState, estimate: TargetEstimate, dt: float) -> FollowSetpoint:
        """One tick with the target `estimate`, `dt` seconds after the last."""
        position = state.position_ned
        if self.target is None:
            self.target, self.target_velocity = estimate.position.copy(), estimate.velocity.copy()
            self.course = bearing(position, self.target)
            self.orbit = bearing(self.target, position)
        else:
            self.target, self.target_velocity = filter_step(self.target, self.target_velocity, estimate.position,
                                                            estimate.velocity, dt)  # fmt: skip
        distance = self.params["FLW_TGT_DST"]
        self.course = updated_course(self.course, self.target_velocity, estimate.velocity)
        goal = self.course + math.radians(self.params["FLW_TGT_FA"])
        self.orbit, self.orbit_rate = orbit_step(self.orbit, self.orbit_rate, goal,
                                                 self.params["FLW_TGT_MAX_VEL"] / distance,
                                                 ORBIT_ACCELERATION / distance, dt)  # fmt: skip
        if math.hypot(*(self.target[0:2] - position[0:2])) > YAW_MIN_DISTANCE:
            self.heading = bearing(position, self.target)
        if self.home_down - float(position[2]) < SAFETY_HEIGHT:
            return FollowSetpoint(position.copy(), np.array([0.0, 0.0, -ASCENT_SPEED]), ascend=True)
        down = self._follow_down()
        if abs(down - float(position[2])) >= ALTITUDE_ACCEPTANCE:
            return FollowSetpoint(np.array([position[0], position[1], down]), np.zeros(3))
        radial = np.array([math.cos(self.orbit), math.sin(self.orbit)])
        tangential = np.array([-radial[1], radial[0]]) * self.orbit_rate * distance
        desired = np.array([*(self.target[0:2] + radial * distance), down])
        return FollowSetpoint(desired, np.array([*(self.target_velocity[0:2] + tangential), 0.0]))
