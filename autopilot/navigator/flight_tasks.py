"""The position logic of Hold, Takeoff, Land and Offboard's position set-points (PX4's flight tasks): each turns the
vehicle state into a velocity set-point (NED, m/s) for the velocity controller (docs/mavlink.md). Runs at the
velocity controller's 100 Hz, in simulation time.

    Hold      brake to a stop (from forward flight the velocity controller decelerates and tilts the rotors
              back), then hold the position where it stopped and the altitude where Hold began: a P controller
              on the position error, bounded by MPC_XY_CRUISE and MPC_Z_VEL_MAX_UP/DN.
    FW Hold   after a transition to fixed wing in Hold: a clockwise circle of NAV_LOITER_RAD at FW_AIRSPD_TRIM
              (a vector field: the set-point turns towards the circle, 45 deg at 50 m off it), altitude held.
    Takeoff   climb at MPC_TKO_SPEED over the takeoff point to the target altitude.
    Land      brake like Hold, then descend at MPC_Z_VEL_MAX_DN, and at MPC_LAND_SPEED below MPC_LAND_ALT2.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigator.guidance import TICK_S, limit_norm
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.vehicle_state import VehicleState

BRAKED_SPEED = 1.0  # m/s: Hold locks its position once the horizontal speed is below this
LOITER_CONVERGENCE = 50.0  # m off the circle where the set-point points 45 deg towards it
TAKEOFF_DONE_M = 0.5  # m below the takeoff altitude: takeoff complete


class FlightTasks:
    """Targets of the current mode and the velocity set-points that reach them."""

    def __init__(self, params: ParameterStore) -> None:
        self.params = params
        self.hold_xy: np.ndarray | None = None  # None while braking
        self.hold_down = 0.0
        self.loiter_center: np.ndarray | None = None  # set: fixed-wing hold
        self.takeoff_xy = np.zeros(2)
        self.tracked_velocity = np.zeros(3)  # Offboard position: the velocity set-point of the last tick
        self.takeoff_down = -2.5

    # ---- entering modes ------------------------------------------------------------------------------------
    def start_hold(self, state: VehicleState, down: float | None = None) -> None:
        """Hold from here: brake, then hold where the vehicle stopped; altitude `down` (default: the current)."""
        self.hold_xy = None
        self.loiter_center = None
        self.hold_down = float(state.position_ned[2]) if down is None else down

    def start_fixed_wing_hold(self, state: VehicleState) -> None:
        """Circle clockwise through the current position, starting along the current heading."""
        yaw = float(state.euler[2])
        radius = self.params["NAV_LOITER_RAD"]
        self.loiter_center = state.position_ned[0:2] + radius * np.array([-math.sin(yaw), math.cos(yaw)])

    def start_takeoff(self, state: VehicleState, target_down: float) -> None:
        self.takeoff_xy = state.position_ned[0:2].copy()
        self.takeoff_down = target_down

    def start_land(self, state: VehicleState) -> None:
        self.hold_xy = None
        self.loiter_center = None

    # ---- set-points ------------------------------------------------------------------------------------------
    def _vertical_to(self, state: VehicleState, down: float, climb_limit: float | None = None) -> float:
        p = self.params
        up = p["MPC_Z_VEL_MAX_UP"] if climb_limit is None else climb_limit
        vz = p["MPC_Z_P"] * (down - float(state.position_ned[2]))
        return min(max(vz, -up), p["MPC_Z_VEL_MAX_DN"])

    def _horizontal_hold(self, state: VehicleState) -> np.ndarray:
        """Brake, then a P controller on the position where the vehicle stopped."""
        if self.hold_xy is None:
            if math.hypot(state.velocity_ned[0], state.velocity_ned[1]) > BRAKED_SPEED:
                return np.zeros(2)
            self.hold_xy = state.position_ned[0:2].copy()
        p = self.params
        return limit_norm(p["MPC_XY_P"] * (self.hold_xy - state.position_ned[0:2]), p["MPC_XY_CRUISE"])

    def hold(self, state: VehicleState) -> np.ndarray:
        if self.loiter_center is not None:
            return self._loiter(state)
        return np.array([*self._horizontal_hold(state), self._vertical_to(state, self.hold_down)])

    def _loiter(self, state: VehicleState) -> np.ndarray:
        p = self.params
        offset = state.position_ned[0:2] - self.loiter_center
        distance = float(np.hypot(*offset))
        if distance < 1.0:
            outward = np.array([1.0, 0.0])
        else:
            outward = offset / distance
        tangent = np.array([-outward[1], outward[0]])  # clockwise seen from above (NED)
        angle = math.atan((distance - p["NAV_LOITER_RAD"]) / LOITER_CONVERGENCE)
        direction = math.cos(angle) * tangent - math.sin(angle) * outward
        return np.array([*(p["FW_AIRSPD_TRIM"] * direction), self._vertical_to(state, self.hold_down)])

    def takeoff(self, state: VehicleState) -> np.ndarray:
        p = self.params
        horizontal = limit_norm(p["MPC_XY_P"] * (self.takeoff_xy - state.position_ned[0:2]), p["MPC_XY_CRUISE"])
        return np.array([*horizontal, self._vertical_to(state, self.takeoff_down, p["MPC_TKO_SPEED"])])

    def start_tracking(self, state: VehicleState) -> None:
        """Offboard begins: the position set-points' velocity starts from the vehicle's."""
        self.tracked_velocity = state.velocity_ned.copy()

    def track(self, state: VehicleState, position: np.ndarray, feed_forward: np.ndarray) -> np.ndarray:
        """Offboard position (at 100 Hz): the velocity that stops at the position with MPC_ACC_HOR (sqrt(2 a d),
        P near it), plus the feed-forward, bounded by MPC_XY_VEL_MAX and MPC_Z_VEL_MAX_UP/DN, and changed by at
        most MPC_ACC_HOR per second, so the velocity controller gets a ramp, not a step (PX4 shapes its position
        set-points with jerk-limited trajectories for the same reason)."""
        p = self.params
        accel = p["MPC_ACC_HOR"]
        error = position[0:2] - state.position_ned[0:2]
        distance = float(np.hypot(*error))
        speed = min(math.sqrt(2.0 * accel * distance), p["MPC_XY_P"] * distance)
        horizontal = limit_norm(error * (speed / distance if distance > 0 else 0.0) + feed_forward[0:2],
                                 p["MPC_XY_VEL_MAX"])  # fmt: skip
        vz = p["MPC_Z_P"] * (position[2] - float(state.position_ned[2])) + feed_forward[2]
        wanted = np.array([*horizontal, min(max(vz, -p["MPC_Z_VEL_MAX_UP"]), p["MPC_Z_VEL_MAX_DN"])])
        step = wanted - self.tracked_velocity
        limit = accel * TICK_S
        norm = math.hypot(*step.tolist())
        self.tracked_velocity = self.tracked_velocity + (step * (limit / norm) if norm > limit else step)
        return self.tracked_velocity.copy()

    def takeoff_done(self, state: VehicleState) -> bool:
        return float(state.position_ned[2]) <= self.takeoff_down + TAKEOFF_DONE_M

    def land(self, state: VehicleState) -> np.ndarray:
        p = self.params
        horizontal = self._horizontal_hold(state)
        braking = self.hold_xy is None
        height = -float(state.position_ned[2])
        speed = p["MPC_LAND_SPEED"] if height < p["MPC_LAND_ALT2"] else p["MPC_Z_VEL_MAX_DN"]
        # While braking from forward flight, hold the altitude (a descent would fight the back transition).
        return np.array([*horizontal, 0.0 if braking else speed])
