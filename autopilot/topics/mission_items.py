"""Mission items as this vehicle stores them, and the checks every item passes before it is stored (an upload over
MAVLink and the mission file alike). Pure functions, no I/O: the mission protocol (autopilot/mavlink/missions.py)
and the mission store (autopilot/storage/mission_store.py) use them, the navigator reads `MissionItem`s.

A `MissionItem` is a MISSION_ITEM_INT without its addressing: the frame and command as sent, autocontinue,
param1..4 (NaN allowed: "use the default" in MAVLink), x and y as int32 (degE7 in the global frames, PX4's rounded
param5/param6 in MAV_FRAME_MISSION) and z (altitude in m, or param7). A legacy MISSION_ITEM (float degrees) is
converted to the same form on arrival (`from_float_coordinates`).

What is supported (docs/missions.md): per mission type, the commands below; positional commands in the
global frames (GLOBAL, GLOBAL_RELATIVE_ALT and their _INT forms), the others in MAV_FRAME_MISSION, as PX4 parses them
(its mavlink_mission.cpp).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from transport.mavlink import mavlink as M

MISSION = M.MAV_MISSION_TYPE_MISSION
FENCE = M.MAV_MISSION_TYPE_FENCE
RALLY = M.MAV_MISSION_TYPE_RALLY
MISSION_TYPES = (MISSION, FENCE, RALLY)
TYPE_NAMES = {MISSION: "mission", FENCE: "fence", RALLY: "rally"}

# Most items per type: PX4's dataman sizes (missions: the 500 of PX4's smaller boards; fence 64; rally 8).
MAX_ITEMS = {MISSION: 500, FENCE: 64, RALLY: 8}

GLOBAL_FRAMES = frozenset({M.MAV_FRAME_GLOBAL, M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_FRAME_GLOBAL_INT,
                           M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})  # fmt: skip
FLOAT_FRAME_OF = {M.MAV_FRAME_GLOBAL_INT: M.MAV_FRAME_GLOBAL,
                  M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: M.MAV_FRAME_GLOBAL_RELATIVE_ALT}  # fmt: skip

FENCE_POLYGONS = frozenset({M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION})
FENCE_CIRCLES = frozenset({M.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION})

# The mission items with a position the vehicle flies to (PX4's MissionBlock::item_contains_position).
NAVIGATION = frozenset({M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_TAKEOFF, M.MAV_CMD_NAV_VTOL_TAKEOFF, M.MAV_CMD_NAV_LAND,
                        M.MAV_CMD_NAV_VTOL_LAND, M.MAV_CMD_NAV_LOITER_TIME, M.MAV_CMD_NAV_LOITER_UNLIM,
                        M.MAV_CMD_NAV_LOITER_TO_ALT})  # fmt: skip
LANDS = frozenset({M.MAV_CMD_NAV_LAND, M.MAV_CMD_NAV_VTOL_LAND})
# Payload items: PX4 hands them to its camera, gimbal and actuator modules and goes on to the next item at once
# (MissionBlock's "action commands that complete instantaneously"). This airframe carries no payload, so they are
# stored, downloaded as sent and passed when flown (docs/missions.md); a plan with camera items
# (QGroundControl's surveys, a gimbal pointed down) flies as its waypoints say.
PAYLOAD = frozenset({
    M.MAV_CMD_DO_TRIGGER_CONTROL, M.MAV_CMD_DO_DIGICAM_CONTROL, M.MAV_CMD_IMAGE_START_CAPTURE,
    M.MAV_CMD_IMAGE_STOP_CAPTURE, M.MAV_CMD_VIDEO_START_CAPTURE, M.MAV_CMD_VIDEO_STOP_CAPTURE,
    M.MAV_CMD_DO_CONTROL_VIDEO, M.MAV_CMD_DO_MOUNT_CONFIGURE, M.MAV_CMD_DO_MOUNT_CONTROL,
    M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, M.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, M.MAV_CMD_DO_SET_CAM_TRIGG_DIST,
    M.MAV_CMD_OBLIQUE_SURVEY, M.MAV_CMD_DO_SET_CAM_TRIGG_INTERVAL, M.MAV_CMD_SET_CAMERA_MODE, M.MAV_CMD_SET_CAMERA_ZOOM,
    M.MAV_CMD_SET_CAMERA_FOCUS, M.MAV_CMD_SET_CAMERA_SOURCE, M.MAV_CMD_DO_SET_ACTUATOR,
})  # fmt: skip
# The region of interest (PX4's vehicle_roi), which turns the nose on a mission's legs (mission_flight.py). DO_SET_ROI
# takes MAV_ROI_LOCATION or MAV_ROI_NONE with a position, MAV_ROI_NONE, _WPNEXT or _WPINDEX without (as PX4 parses it).
ROI_AT_POSITION = frozenset({M.MAV_CMD_DO_SET_ROI_LOCATION, M.MAV_CMD_DO_SET_ROI})
ROI_WITHOUT_POSITION = frozenset({M.MAV_CMD_DO_SET_ROI_NONE, M.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET, M.MAV_CMD_DO_SET_ROI})
ROI_COMMANDS = ROI_AT_POSITION | ROI_WITHOUT_POSITION
ROI_MODES_AT_POSITION = (M.MAV_ROI_LOCATION, M.MAV_ROI_NONE)
ROI_MODES_WITHOUT_POSITION = (M.MAV_ROI_NONE, M.MAV_ROI_WPNEXT, M.MAV_ROI_WPINDEX)

# Commands with a position (global frames) and without (MAV_FRAME_MISSION), per mission type.
POSITIONAL: dict[int, frozenset[int]] = {
    MISSION: NAVIGATION | ROI_AT_POSITION,
    FENCE: FENCE_POLYGONS | FENCE_CIRCLES,
    RALLY: frozenset({M.MAV_CMD_NAV_RALLY_POINT}),
}  # fmt: skip
NON_POSITIONAL: dict[int, frozenset[int]] = {
    MISSION: frozenset({M.MAV_CMD_NAV_RETURN_TO_LAUNCH, M.MAV_CMD_NAV_DELAY, M.MAV_CMD_DO_VTOL_TRANSITION,
                        M.MAV_CMD_DO_CHANGE_SPEED, M.MAV_CMD_DO_JUMP, M.MAV_CMD_DO_SET_HOME,
                        M.MAV_CMD_DO_LAND_START})  # where the mission's landing starts (Return, RTL_TYPE 1)
             | PAYLOAD | ROI_WITHOUT_POSITION,
    FENCE: frozenset(),
    RALLY: frozenset(),
}  # fmt: skip
ALL_COMMANDS = frozenset().union(*POSITIONAL.values(), *NON_POSITIONAL.values())

INT32_MAX = 2**31 - 1
LAT_LIMIT_E7 = 900_000_000
LON_LIMIT_E7 = 1_800_000_000


@dataclass(frozen=True, slots=True)
class MissionItem:
    frame: int  # MAV_FRAME, as received
    command: int  # MAV_CMD
    autocontinue: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: int  # latitude degE7 (global frames) or param5
    y: int  # longitude degE7 (global frames) or param6
    z: float  # altitude (m) or param7

    @property
    def positional(self) -> bool:
        return self.frame in GLOBAL_FRAMES

    @property
    def latitude_deg(self) -> float:
        return self.x * 1e-7

    @property
    def longitude_deg(self) -> float:
        return self.y * 1e-7

    @property
    def relative_altitude(self) -> bool:
        """z is above home (GLOBAL_RELATIVE_ALT frames), else above mean sea level."""
        return self.frame in (M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)


def from_float_coordinates(frame: int, x: float, y: float) -> tuple[int, int] | int:
    """A legacy MISSION_ITEM's x, y (degrees in the global frames, params otherwise) as the stored int32 pair, or
    the MAV_MISSION_RESULT refusing them (NaN, infinite, beyond int32)."""
    scale = 1e7 if frame in GLOBAL_FRAMES else 1.0
    if not math.isfinite(x) or abs(x * scale) > INT32_MAX:
        return M.MAV_MISSION_INVALID_PARAM5_X
    if not math.isfinite(y) or abs(y * scale) > INT32_MAX:
        return M.MAV_MISSION_INVALID_PARAM6_Y
    return int(round(x * scale)), int(round(y * scale))


def to_float_coordinates(item: MissionItem) -> tuple[float, float]:
    """x, y for a legacy MISSION_ITEM (degrees in the global frames)."""
    if item.positional:
        return item.x * 1e-7, item.y * 1e-7
    return float(item.x), float(item.y)


def mission_type_of_command(command: int) -> int | None:
    for mission_type in MISSION_TYPES:
        if command in POSITIONAL[mission_type] or command in NON_POSITIONAL[mission_type]:
            return mission_type
    return None


_INVALID_PARAMS = (M.MAV_MISSION_INVALID_PARAM1, M.MAV_MISSION_INVALID_PARAM2, M.MAV_MISSION_INVALID_PARAM3,
                   M.MAV_MISSION_INVALID_PARAM4)  # fmt: skip


def check_item(mission_type: int, item: MissionItem) -> int:
    """MAV_MISSION_ACCEPTED, or the MAV_MISSION_RESULT that refuses `item` in a `mission_type` list:
    UNSUPPORTED (a command this vehicle does not know, or a non-positional command in a global frame, as PX4),
    ERROR (a command of another mission type, as PX4; a fence polygon of fewer than 3 vertices, as PX4),
    UNSUPPORTED_FRAME, INVALID_PARAM1..4 (infinite), INVALID_PARAM5_X / PARAM6_Y (latitude, longitude out of range),
    INVALID_PARAM7 (altitude not finite), INVALID_PARAM1 (a fence circle's radius, a DO_JUMP target, a delay)."""
    owner = mission_type_of_command(item.command)
    if owner is None:
        return M.MAV_MISSION_UNSUPPORTED
    if owner != mission_type:
        return M.MAV_MISSION_ERROR
    if item.frame in GLOBAL_FRAMES:
        if item.command not in POSITIONAL[mission_type]:
            return M.MAV_MISSION_UNSUPPORTED
    elif item.frame == M.MAV_FRAME_MISSION:
        if item.command not in NON_POSITIONAL[mission_type]:
            return M.MAV_MISSION_UNSUPPORTED_FRAME
    else:
        return M.MAV_MISSION_UNSUPPORTED_FRAME
    for index, value in enumerate((item.param1, item.param2, item.param3, item.param4)):
        if math.isinf(value):
            return _INVALID_PARAMS[index]
    if item.positional:
        if not -LAT_LIMIT_E7 <= item.x <= LAT_LIMIT_E7:
            return M.MAV_MISSION_INVALID_PARAM5_X
        if not -LON_LIMIT_E7 <= item.y <= LON_LIMIT_E7:
            return M.MAV_MISSION_INVALID_PARAM6_Y
        if not math.isfinite(item.z):
            return M.MAV_MISSION_INVALID_PARAM7
    elif math.isinf(item.z):
        return M.MAV_MISSION_INVALID_PARAM7
    return _check_command_params(item)


def _check_command_params(item: MissionItem) -> int:
    if item.command in FENCE_POLYGONS and not (math.isfinite(item.param1) and item.param1 >= 2.5):
        return M.MAV_MISSION_ERROR  # PX4: "Fence: too few vertices"
    if item.command in FENCE_CIRCLES and not (math.isfinite(item.param1) and item.param1 >= 0):
        return M.MAV_MISSION_INVALID_PARAM1  # PX4 takes a radius of 0 (MAVSDK's geofence example uploads one)
    if item.command == M.MAV_CMD_DO_JUMP and not (math.isfinite(item.param1) and item.param1 >= 0
                                                  and item.param1 == int(item.param1)):  # fmt: skip
        return M.MAV_MISSION_INVALID_PARAM1
    if item.command in (M.MAV_CMD_NAV_DELAY, M.MAV_CMD_NAV_LOITER_TIME) and math.isnan(item.param1):
        return M.MAV_MISSION_INVALID_PARAM1
    if item.command == M.MAV_CMD_DO_SET_ROI:
        modes = ROI_MODES_AT_POSITION if item.positional else ROI_MODES_WITHOUT_POSITION
        if item.param1 not in modes:  # also NaN
            return M.MAV_MISSION_INVALID_PARAM1  # as PX4
    return M.MAV_MISSION_ACCEPTED


def result_name(result: int) -> str:
    """'MAV_MISSION_UNSUPPORTED' for a MAV_MISSION_RESULT."""
    entry = M.enums["MAV_MISSION_RESULT"].get(result)
    return entry.name if entry is not None else str(result)
