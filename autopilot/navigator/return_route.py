"""AUTO.RTL's route (PX4's rtl_direct): the destination, the return altitude and the targets flown to land there
(docs/failsafes.md, "Return and rally points").

The destination (RTL_TYPE): 0 the closest of home and the rally points; 1 the closest of the rally points and the
mission's landing (the mission flies that part itself: autopilot/navigator/mission_flight.py), home only when there is
neither (PX4's RTL_TYPE 1 with the vehicle out of its hover: PX4 also counts home while a VTOL hovers).

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
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from autopilot.navigator.auto_flight import Climb, FlyTo, HoldAt, LandAt, Target
from autopilot.navigator.guidance import ORIGIN_NED
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.mission_items import LANDS, MissionItem
from autopilot.topics.vehicle_state import VehicleState
from transport.mavlink import mavlink as M

LANDING_APPROACH_RADIUS = 1.0  # m: the FlyTo before a landing stops within this of the landing point
RTL_HOME_OR_RALLY, RTL_MISSION_LANDING = 0, 1  # RTL_TYPE


@dataclass(frozen=True)
class MissionLanding:
    """The mission's landing: its DO_LAND_START item and where the land item after it lands (NE)."""

    start_seq: int
    point: np.ndarray


def mission_landing(items: tuple[MissionItem, ...],
                    position_of: Callable[[MissionItem], np.ndarray | None]) -> MissionLanding | None:  # fmt: skip
    """The first DO_LAND_START with a land item after it that has a position (PX4's mission land_start_index and
    land_index), or None."""
    starts = [seq for seq, item in enumerate(items) if item.command == M.MAV_CMD_DO_LAND_START]
    if not starts:
        return None
    land = next((item for item in items[starts[0] :] if item.command in LANDS), None)
    point = None if land is None else position_of(land)
    return None if point is None else MissionLanding(starts[0], point[0:2].copy())


def return_destination(
    rtl_type: int,
    position_ned: np.ndarray,
    rally_points: list[np.ndarray],
    home_ned: np.ndarray,
    landing: MissionLanding | None,
) -> np.ndarray | MissionLanding:
    """Where Return goes (the module's docstring): a point (NE) or the mission's landing."""
    if rtl_type != RTL_MISSION_LANDING:
        return closest_safe_point(position_ned, rally_points, home_ned)
    candidates: list[np.ndarray | MissionLanding] = [point[0:2].copy() for point in rally_points]
    if landing is not None:
        candidates.append(landing)
    if not candidates:
        return home_ned[0:2].copy()
    return min(candidates, key=lambda c: float(np.hypot(*((c.point if isinstance(c, MissionLanding) else c)
                                                           - position_ned[0:2]))))  # fmt: skip


def closest_safe_point(position_ned: np.ndarray, rally_points: list[np.ndarray],
                       home_ned: np.ndarray = ORIGIN_NED) -> np.ndarray:  # fmt: skip
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


def climb_to_return_height(params: ParameterStore, state: VehicleState, destination: np.ndarray,
                           home_ned: np.ndarray) -> tuple[float, Climb]:  # fmt: skip
    """The return altitude (m above home) towards `destination` (NE) and the climb to it over here."""
    distance = float(np.hypot(*(state.position_ned[0:2] - destination)))
    home_down = float(home_ned[2])
    height = return_height(home_down - float(state.position_ned[2]), distance, params["RTL_RETURN_ALT"],
                           params.get_int("RTL_CONE_ANG"), params["RTL_MIN_DIST"], params["NAV_ACC_RAD"])  # fmt: skip
    return height, Climb(state.position_ned[0:2].copy(), home_down - height, params["MPC_Z_VEL_MAX_UP"])


def plan_return(params: ParameterStore, state: VehicleState, destination: np.ndarray,
                home_ned: np.ndarray) -> ReturnPlan:  # fmt: skip
    """The Return from here to `destination` (NE): return altitude and the route (the module's docstring)."""
    height, climb = climb_to_return_height(params, state, destination, home_ned)
    home_down = float(home_ned[2])
    down = home_down - height
    route: list[Target] = [climb, FlyTo(np.array([*destination, down]), LANDING_APPROACH_RADIUS)]
    delay = params["RTL_LAND_DELAY"]
    if delay != 0:
        loiter = np.array([*destination, max(down, home_down - params["RTL_DESCEND_ALT"])])
        route += [FlyTo(loiter, LANDING_APPROACH_RADIUS), HoldAt(loiter, None if delay < 0 else delay)]
    if delay >= 0:
        route.append(LandAt(destination.copy()))
    return ReturnPlan(height, route)
