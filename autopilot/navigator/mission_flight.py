"""AUTO.MISSION and AUTO.RTL as routes (docs/missions.md and "Return"): the stored mission stepped
through item by item, each navigation item turned into targets for AutoFlight (autopilot/navigator/auto_flight.py), the
progress reported to the mission store (MISSION_CURRENT, MISSION_ITEM_REACHED).

    NAV_WAYPOINT                  FlyTo, acceptance radius param2 (0: NAV_ACC_RAD), yaw param4
    NAV_TAKEOFF, NAV_VTOL_TAKEOFF Climb over the current position to the item's altitude, yaw param4
    NAV_LAND, NAV_VTOL_LAND       FlyTo over the point (at the current altitude), LandAt (lat/lon 0: here), yaw
                                  param4
    NAV_LOITER_TIME / _UNLIM      FlyTo, then HoldAt for param1 s (for ever); _UNLIM: yaw param4 (LOITER_TIME's
                                  param4 is not a yaw)
    NAV_LOITER_TO_ALT             FlyTo: over the point at the item's altitude (PX4's multicopter flies it so;
                                  QGroundControl's landing patterns descend with it)
    NAV_DELAY                     HoldAt here for param1 s
    NAV_RETURN_TO_LAUNCH          the Return route (to the closest of home and the rally points)
    DO_CHANGE_SPEED               param2 > 0: the cruise speed of the following legs (-1: back to the defaults)
    DO_JUMP                       to item param1, param2 times
    DO_VTOL_TRANSITION            param1 MAV_VTOL_STATE_FW: the following legs at FW_AIRSPD_TRIM, _MC: at
                                  MPC_XY_CRUISE (the set-point's speed is what switches the PID's phases);
                                  it cancels a DO_CHANGE_SPEED; a land or return item in the FW phase is
                                  flown as Return flies (braked into), as PX4 back-transitions for it
    DO_SET_HOME                   accepted and passed
    DO_SET_ROI_LOCATION, DO_SET_ROI (LOCATION)
                                  the nose points at the item's latitude/longitude on the following legs
                                  (multicopter; within NAV_ACC_RAD of it, the last heading is kept)
    DO_SET_ROI_WPNEXT_OFFSET, DO_SET_ROI (WPNEXT)
                                  the nose points at the item being flown to, plus param7 degrees (the offset item)
    DO_SET_ROI_NONE, DO_SET_ROI (NONE, WPINDEX)
                                  back to the items' own yaw (PX4's heading update ignores WPINDEX)
    payload items (camera, gimbal, video, actuator; mission_items.PAYLOAD)
                                  passed at once: this airframe carries no payload (PX4 forwards them to its
                                  payload modules and goes on at once)

The region of interest is the vehicle's, as PX4's navigator keeps it: it lasts until another ROI item or command
changes it, a new mission is stored or the mission starts again from its first item; only Mission and Return's
mission landing fly by it (Return's own route, Go-to and Hold keep their own yaw rules), and not on takeoff and
landing items.

A mission with a DO_VTOL_TRANSITION item flies as PX4 flies it: in multicopter until the item to fixed wing,
back to multicopter at the item to MC (so the PID back-transitions before its landing). A mission without one
chooses each leg's speed by its length: the unified MPC transitions by itself (docs/missions.md).

A yaw (param4, degrees; NaN: the velocity controllers' own rule, the nose along the leg) is the item's targets' yaw
set-point (autopilot/navigator/auto_flight.py: a waypoint with one is reached once the heading is within MIS_YAW_ERR, or
at once with a yaw timeout, MIS_YAW_TMT > 0).

A mission started on the ground whose first navigation item is a waypoint or loiter (no takeoff item) takes off
first, as PX4's mission does: a climb over the current position to the higher of the item's altitude and
MIS_TAKEOFF_ALT above the ground, then the item. When the mission ends it holds at the last position (PX4: loiter at
the last waypoint), MISSION_STATE_COMPLETE.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from autopilot.navigator.auto_flight import AutoFlight, Climb, FlyTo, HoldAt, LandAt, Target
from autopilot.navigator.return_route import (
    LANDING_APPROACH_RADIUS,
    MissionLanding,
    closest_safe_point,
    mission_landing,
    plan_return,
)
from autopilot.storage.mission_store import MissionStore
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.home_position import HomeReader
from autopilot.topics.mission_items import LANDS, ROI_COMMANDS, MissionItem
from autopilot.topics.region_of_interest import RegionOfInterest, roi_mode, wpnext_offset_deg
from autopilot.topics.vehicle_state import VehicleState
from transport.geodesy import ned_from_geodetic
from transport.mavlink import mavlink as M

YAW_ITEMS = (
    M.MAV_CMD_NAV_WAYPOINT,
    M.MAV_CMD_NAV_LOITER_UNLIM,
    M.MAV_CMD_NAV_TAKEOFF,
    M.MAV_CMD_NAV_VTOL_TAKEOFF,
    M.MAV_CMD_NAV_LAND,
    M.MAV_CMD_NAV_VTOL_LAND,
)  # param4 is their yaw (deg)
TAKEOFFS = (M.MAV_CMD_NAV_TAKEOFF, M.MAV_CMD_NAV_VTOL_TAKEOFF)
TAKEOFF_BEFORE = (
    M.MAV_CMD_NAV_WAYPOINT,
    M.MAV_CMD_NAV_LOITER_TIME,
    M.MAV_CMD_NAV_LOITER_UNLIM,
    M.MAV_CMD_NAV_LOITER_TO_ALT,
)


def item_yaw(item: MissionItem) -> float | None:
    """The item's yaw (rad) from param4 (degrees) for the items that have one; None when NaN or not theirs."""
    if item.command not in YAW_ITEMS or not math.isfinite(item.param4):
        return None
    return math.radians(item.param4)


def region_of_interest(item: MissionItem, ned_of: Callable[[MissionItem], np.ndarray]) -> RegionOfInterest | None:
    """The region of interest a DO_SET_ROI_* item sets (None: none), `ned_of` giving a positional item's place."""
    mode = roi_mode(item.command, item.param1)  # the upload's checks took only the modes each frame has
    if mode == M.MAV_ROI_LOCATION:
        return RegionOfInterest(ned_of(item)[0:2])
    if mode == M.MAV_ROI_WPNEXT:
        offset = wpnext_offset_deg(item.command, item.z)  # param7 (deg; NaN: MAVLink's default, none)
        return RegionOfInterest(None, math.radians(offset if math.isfinite(offset) else 0.0))
    return None


def takeoff_down(item_down: float, ground_down: float, takeoff_alt: float) -> float:
    """The altitude (NED down) of the takeoff a mission started on the ground flies before its first item: the
    item's, but at least `takeoff_alt` (MIS_TAKEOFF_ALT) above the ground (PX4's calculate_takeoff_altitude)."""
    return min(item_down, ground_down - takeoff_alt)


VTOL_FW, VTOL_MC = M.MAV_VTOL_STATE_FW, M.MAV_VTOL_STATE_MC


class MissionFlight:
    """Steps through the stored mission from its current item, handing AutoFlight its targets."""

    def __init__(self, params: ParameterStore, store: MissionStore, homes: HomeReader, auto: AutoFlight,
                 landed: Callable[[], bool]) -> None:  # fmt: skip
        self.params = params
        self.landed_now = landed
        self.store = store
        self.homes = homes
        self.auto = auto
        self.seq = 0
        self.complete = False
        self._jumps: dict[int, int] = {}  # DO_JUMP item -> jumps done
        self._version = -1
        self._takeoff_first = False  # started on the ground: climb before the first navigation item
        self._climb_first: Climb | None = None  # Return's climb before its mission landing
        self.roi: RegionOfInterest | None = None  # the last DO_SET_ROI_* item's or command's
        self._roi_mission: tuple[MissionItem, ...] = ()  # the mission stored when it was set
        self._roi_after_end = False  # it was set after that mission had ended (a restart keeps it)

    @property
    def items(self) -> tuple[MissionItem, ...]:
        return self.store.snapshot.mission

    def start(self, state: VehicleState) -> str | None:
        """Fly from the store's current item (a finished mission starts again from item 0); the reason if not."""
        if not self.items:
            return "Mission denied: no mission stored"
        seq = self.store.snapshot.current
        if self.store.snapshot.state == M.MISSION_STATE_COMPLETE or seq >= len(self.items):
            seq = 0
            if not self._roi_after_end:
                self.roi = None  # PX4 resets the region of interest with the mission
        self._prepare(state)
        self._takeoff_first = self.landed_now()
        self._begin(state, seq)
        return None

    def landing_pattern(self) -> MissionLanding | None:
        """The stored mission's landing (its DO_LAND_START and the land item after it), or None."""
        return mission_landing(self.items, self.item_position)

    def landing_underway(self, landing: MissionLanding) -> bool:
        """The mission flown last is at or past its landing's DO_LAND_START, not over and not changed since."""
        return not self.complete and not self.changed_elsewhere and self.seq >= landing.start_seq

    @property
    def changed_elsewhere(self) -> bool:
        """The store changed (an upload, a current item set) since this flight last stepped."""
        return self.store.version != self._version

    def point_at(self, roi: RegionOfInterest | None, turn_now: bool = True) -> None:
        """The vehicle's region of interest from now on (it lasts until a new mission is stored or the mission
        starts again from its first item, as PX4's navigator resets it); `turn_now`: this mission is being flown
        (Mission, or Return's mission landing), which turns to it at once."""
        self.roi = roi
        self._roi_mission = self.items
        self._roi_after_end = self.complete
        if turn_now:
            self.auto.point_at(roi)

    def _forget_roi_of_another_mission(self) -> None:
        if self.items is not self._roi_mission:
            self.roi = None
            self.auto.point_at(None)

    def fly_landing(self, state: VehicleState, landing: MissionLanding, climb: Climb) -> None:
        """Return's mission landing (RTL_TYPE 1): `climb` over here, then the mission from its DO_LAND_START item."""
        self._prepare(state)
        self._climb_first = climb
        self._begin(state, landing.start_seq)

    def _prepare(self, state: VehicleState) -> None:
        self._jumps = {}
        self._takeoff_first = False
        self._climb_first = None
        self.auto.mission_speed = None
        self.auto.start(state, [])
        self._forget_roi_of_another_mission()
        self.auto.point_at(self.roi)
        transitions = any(item.command == M.MAV_CMD_DO_VTOL_TRANSITION for item in self.items)
        self.auto.forward_flight = False if transitions else None

    @property
    def landing(self) -> bool:
        return self.auto.descending

    def rally_points(self) -> list[np.ndarray]:
        """The stored rally points, NED from the local origin."""
        return [self._position(np.zeros(3), item) for item in self.store.snapshot.rally]

    def landed(self, state: VehicleState) -> None:
        """Touchdown on a land item: it is reached, the mission goes on (usually to its end)."""
        self._item_done(state)

    def step(self, state: VehicleState) -> np.ndarray:
        if self.changed_elsewhere and not self.complete:  # a new mission or current item
            self._forget_roi_of_another_mission()
            self._begin(state, self.store.snapshot.current if self.items else 0)
        elif self.auto.finished and not self.complete:
            self._item_done(state)
        return self.auto.step(state)

    # ---- items -----------------------------------------------------------------------------------------------------
    def _item_done(self, state: VehicleState) -> None:
        self.store.reached(self.seq)
        self._begin(state, self.seq + 1)

    def _progress(self, seq: int, mission_state: int) -> None:
        self.store.set_progress(seq, mission_state)
        self._version = self.store.version

    def _begin(self, state: VehicleState, seq: int) -> None:
        """Do the DO_ items from `seq` on, then fly the first navigation item (or hold: the mission ended)."""
        for _ in range(len(self.items) * 4 + 4):  # DO_JUMP loops are bounded by their counts
            if seq >= len(self.items):
                self._end(state)
                return
            item = self.items[seq]
            if item.command == M.MAV_CMD_DO_JUMP:
                done = self._jumps.get(seq, 0)
                if done < item.param2 and 0 <= int(item.param1) < len(self.items):
                    self._jumps[seq] = done + 1
                    seq = int(item.param1)
                else:
                    seq += 1
                continue
            if item.command == M.MAV_CMD_DO_CHANGE_SPEED:
                self.auto.mission_speed = item.param2 if item.param2 > 0 else None
            if item.command in ROI_COMMANDS:
                self.point_at(region_of_interest(item, self._place))
            if item.command == M.MAV_CMD_DO_VTOL_TRANSITION and int(item.param1) in (VTOL_FW, VTOL_MC):
                self.auto.forward_flight = int(item.param1) == VTOL_FW
                self.auto.mission_speed = None  # as PX4's navigator, a new phase flies its own default cruise
            if (item.command in LANDS or item.command == M.MAV_CMD_NAV_RETURN_TO_LAUNCH) and self.auto.forward_flight:
                self.auto.forward_flight = None  # braked into, as Return flies (PX4 back-transitions for these)
            here = state.position_ned.copy()
            if self._climb_first is not None:
                here[2] = self._climb_first.down  # the item starts at the return altitude
            targets = self._targets(state, here, item)
            if targets and self._climb_first is not None:
                targets.insert(0, self._climb_first)
                self._climb_first = None
            if targets and self._takeoff_first:
                self._takeoff_first = False
                if item.command in TAKEOFF_BEFORE:
                    item_down = float(self._position(state.position_ned, item)[2])
                    down = takeoff_down(item_down, float(state.position_ned[2]), self.params["MIS_TAKEOFF_ALT"])
                    targets.insert(0, Climb(state.position_ned[0:2].copy(), down, self.params["MPC_TKO_SPEED"]))
            if targets:
                self.seq = seq
                self.complete = False
                self._progress(seq, M.MISSION_STATE_ACTIVE)
                self.auto.follow(state, targets)
                return
            seq += 1
        self._end(state)

    def _end(self, state: VehicleState) -> None:
        last = len(self.items) - 1
        self.seq = max(last, 0)
        self.complete = True
        self._progress(self.seq, M.MISSION_STATE_COMPLETE)
        self.auto.follow(state, [HoldAt(state.position_ned.copy(), None)])

    def item_position(self, item: MissionItem) -> np.ndarray | None:
        """The item's NED position; None when it flies where the vehicle is then (latitude and longitude 0)."""
        return None if item.x == 0 and item.y == 0 else self._place(item)

    def _place(self, item: MissionItem) -> np.ndarray:
        """A positional item's NED position from its latitude, longitude and altitude (relative to home or AMSL)."""
        origin = self.homes.origin
        north, east, _ = ned_from_geodetic(origin, item.latitude_deg, item.longitude_deg, origin.alt)
        return np.array([north, east, self._down(item)])

    def _down(self, item: MissionItem) -> float:
        return self.homes.position.down - item.z if item.relative_altitude else self.homes.origin.alt - item.z

    def _position(self, here: np.ndarray, item: MissionItem) -> np.ndarray:
        """The item's NED position; latitude and longitude 0: over `here`, the vehicle's."""
        if item.x == 0 and item.y == 0:
            return np.array([float(here[0]), float(here[1]), self._down(item)])
        return self._place(item)

    def _targets(self, state: VehicleState, here: np.ndarray, item: MissionItem) -> list[Target]:
        """The item's targets, flown from `here` (NED: the vehicle's position, at the altitude it will be at when
        the item starts)."""
        p = self.params
        command, yaw = item.command, item_yaw(item)
        if command == M.MAV_CMD_NAV_WAYPOINT:
            radius = item.param2 if math.isfinite(item.param2) and item.param2 > 0 else p["NAV_ACC_RAD"]
            return [FlyTo(self._position(here, item), radius, yaw=yaw)]
        if command == M.MAV_CMD_NAV_LOITER_TO_ALT:
            return [FlyTo(self._position(here, item), p["NAV_ACC_RAD"])]
        if command in TAKEOFFS:
            down = float(self._position(here, item)[2])
            return [Climb(here[0:2].copy(), down, p["MPC_TKO_SPEED"], yaw)]
        if command in LANDS:
            point = self._position(here, item)
            point[2] = float(here[2])
            return [FlyTo(point, LANDING_APPROACH_RADIUS, yaw=yaw, approach=True), LandAt(point[0:2].copy(), yaw)]
        if command in (M.MAV_CMD_NAV_LOITER_TIME, M.MAV_CMD_NAV_LOITER_UNLIM):
            point = self._position(here, item)
            seconds = max(item.param1, 0.0) if command == M.MAV_CMD_NAV_LOITER_TIME else None
            return [FlyTo(point, p["NAV_ACC_RAD"], yaw=yaw), HoldAt(point, seconds, yaw)]
        if command == M.MAV_CMD_NAV_DELAY:
            return [HoldAt(here.copy(), max(item.param1, 0.0))]
        if command == M.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            home = self.homes.position.ned
            return plan_return(p, state, closest_safe_point(state.position_ned, self.rally_points(), home), home).route
        return []  # DO_CHANGE_SPEED, DO_VTOL_TRANSITION, DO_SET_ROI_* (done above), DO_SET_HOME, payload: nothing to fly
