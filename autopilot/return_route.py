"""AUTO.RTL's route (PX4's RTL_TYPE 0, its rtl_direct): the destination, the return altitude and the targets
flown to land there (docs/failsafes.md, "Return and rally points").

    climb    over here to the return altitude, if lower (return_height: RTL_RETURN_ALT, RTL_CONE_ANG within
             RTL_MIN_DIST of the destination)
    return   to the closest of home and the rally points, at the return altitude
    loiter   RTL_LAND_DELAY not 0: descend to RTL_DESCEND_ALT above home (not above the return altitude) over the
             destination and hold there RTL_LAND_DELAY s (-1: for ever, no landing)
    land     descend and land over the destination (the commander disarms after touchdown)

Heights are above home; a rally point's own altitude is not used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from autopilot.auto_flight import Climb, FlyTo, HoldAt, LandAt, Target
from autopilot.parameters import ParameterStore
from autopilot.vehicle_state import VehicleState

LANDING_APPROACH_RADIUS = 1.0  # m: the FlyTo before a landing stops within this of the landing point


def closest_safe_point(position_ned: np.ndarray, rally_points: list[np.ndarray],
                       home_ned: np.ndarray = np.zeros(3)) -> np.ndarray:  # fmt: skip
    """The closest (horizontally) of home and the rally points, (north, east) from the local origin (PX4's RTL_TYPE
    0)."""
    return min([home_ned[0:2].copy(), *(point[0:2] for point in rally_points)],
               key=lambda point: float(np.hypot(*(point - position_ned[0:2]))))  # fmt: skip


def return_height(height: float, distance: float, return_alt: float, cone_deg: int, min_dist: float,
                  acceptance: float) -> float:  # fmt: skip
    """PX4's return altitude (its calculate_return_alt_from_cone_half_angle) as the height above the destination,
    `distance` (m) away horizontally: RTL_RETURN_ALT; within `min_dist` (RTL_MIN_DIST) the height of the cone of
    half-angle `cone_deg` (RTL_CONE_ANG, 1..89) standing on the destination, but at least twice `acceptance`
    (NAV_ACC_RAD); within `acceptance` twice the distance. Never above RTL_RETURN_ALT, never below `height` (where
    the vehicle is now). cone_deg 0: always RTL_RETURN_ALT."""
    if cone_deg <= 0:
        return max(height, return_alt)
    if distance <= acceptance:
        wanted = 2.0 * distance
    else:
        wanted = return_alt
        if distance <= min_dist:
            wanted = min(distance / math.tan(math.radians(min(max(cone_deg, 1), 89))), wanted)
        wanted = max(wanted, 2.0 * acceptance)
    return max(height, min(wanted, return_alt))


@dataclass(frozen=True)
class ReturnPlan:
    height: float  # m above home: the return altitude
    route: list[Target]


def plan_return(params: ParameterStore, state: VehicleState, rally_points: list[np.ndarray],
                home_ned: np.ndarray) -> ReturnPlan:  # fmt: skip
    """The Return from here: destination, return altitude and the route (the module's docstring)."""
    destination = closest_safe_point(state.position_ned, rally_points, home_ned)
    distance = float(np.hypot(*(state.position_ned[0:2] - destination)))
    home_down = float(home_ned[2])
    height = return_height(home_down - float(state.position_ned[2]), distance, params["RTL_RETURN_ALT"],
                           params.get_int("RTL_CONE_ANG"), params["RTL_MIN_DIST"], params["NAV_ACC_RAD"])  # fmt: skip
    down = home_down - height
    route: list[Target] = [Climb(state.position_ned[0:2].copy(), down, params["MPC_Z_VEL_MAX_UP"]),
                           FlyTo(np.array([*destination, down]), LANDING_APPROACH_RADIUS)]  # fmt: skip
    delay = params["RTL_LAND_DELAY"]
    if delay != 0:
        loiter = np.array([*destination, max(down, home_down - params["RTL_DESCEND_ALT"])])
        route += [FlyTo(loiter, LANDING_APPROACH_RADIUS), HoldAt(loiter, None if delay < 0 else delay)]
    if delay >= 0:
        route.append(LandAt(destination.copy()))
    return ReturnPlan(height, route)
