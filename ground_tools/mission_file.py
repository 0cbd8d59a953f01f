"""Mission files as users have them (docs/missions.md): QGroundControl's .plan (JSON, its SimpleItems)
and the QGC WPL 110 text format (.waypoints, as QGroundControl, Mission Planner and MAVProxy write it), read into
the items a MISSION_ITEM_INT upload sends (autopilot/topics/mission_items.py's MissionItem). Pure functions; a file that cannot be flown is a MissionFileError.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from autopilot.topics.mission_items import FLOAT_FRAME_OF, GLOBAL_FRAMES, MissionItem

# MISSION_ITEM_INT carries latitude and longitude as integers (deg * 1e7): the float frames map to their _INT twins.
INT_FRAME_OF = {float_frame: int_frame for int_frame, float_frame in FLOAT_FRAME_OF.items()}
WPL_HEADER = "QGC WPL 110"


class MissionFileError(ValueError):
    """The file is not a mission this tool can fly, with the reason."""


def _number(value: object, where: str) -> float:
    """A parameter: a number, or NaN for QGroundControl's null."""
    if value is None:
        return math.nan
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise MissionFileError(f"{where}: {value!r} is not a number")
    return float(value)


def mission_row(frame: int, command: int, values: list[float], where: str) -> MissionItem:
    """An item from a frame, a command and the seven parameters (param5/6 latitude/longitude in degrees); the
    autopilot checks the rest when it is uploaded."""
    if len(values) != 7:
        raise MissionFileError(f"{where}: {len(values)} parameters, not 7")
    frame = INT_FRAME_OF.get(frame, frame)
    p1, p2, p3, p4, lat, lon, alt = values
    if frame in GLOBAL_FRAMES:
        if not (math.isfinite(lat) and math.isfinite(lon) and abs(lat) <= 90.0 and abs(lon) <= 180.0):
            raise MissionFileError(f"{where}: latitude {lat} and longitude {lon} are not a position")
        x, y = int(round(lat * 1e7)), int(round(lon * 1e7))
    else:
        x, y = (int(v) if math.isfinite(v) else 0 for v in (lat, lon))
    return MissionItem(frame, command, 1, p1, p2, p3, p4, x, y, alt if math.isfinite(alt) else 0.0)


def read_plan(text: str) -> list[MissionItem]:
    """QGroundControl's .plan JSON: the mission's SimpleItems (a ComplexItem, e.g. a QGC survey pattern, is
    refused: QGroundControl itself expands it into waypoints only when it uploads)."""
    try:
        plan = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MissionFileError(f"not JSON: {exc}") from None
    if not isinstance(plan, dict) or plan.get("fileType") != "Plan" or not isinstance(plan.get("mission"), dict):
        raise MissionFileError('not a QGroundControl plan (no "fileType": "Plan" with a "mission")')
    items = plan["mission"].get("items")
    if not isinstance(items, list) or not items:
        raise MissionFileError("the plan has no mission items")
    rows = []
    for index, item in enumerate(items):
        where = f"mission item {index + 1}"
        if not isinstance(item, dict) or item.get("type") != "SimpleItem":
            kind = item.get("complexItemType", item.get("type")) if isinstance(item, dict) else item
            raise MissionFileError(f"{where}: {kind!r} items are not supported (only SimpleItem)")
        params = item.get("params")
        if not isinstance(params, list):
            raise MissionFileError(f"{where}: no params list")
        frame, command = item.get("frame"), item.get("command")
        if not isinstance(frame, int) or not isinstance(command, int):
            raise MissionFileError(f"{where}: frame and command must be integers")
        rows.append(mission_row(frame, command, [_number(v, where) for v in params], where))
    return rows


def read_waypoints(text: str) -> list[MissionItem]:
    """QGC WPL 110: a header line, then tab-separated rows (index, current, frame, command, param1-7,
    autocontinue); row 0 is the home position, not a mission item."""
    lines = [line for line in text.splitlines() if line.strip()]
    if not lines or lines[0].strip() != WPL_HEADER:
        raise MissionFileError(f"not a waypoints file (the first line is not {WPL_HEADER!r})")
    rows = []
    for number, line in enumerate(lines[1:], start=2):
        fields = line.split()
        where = f"line {number}"
        if len(fields) != 12:
            raise MissionFileError(f"{where}: {len(fields)} fields, not 12")
        try:
            index, frame, command = int(fields[0]), int(fields[2]), int(fields[3])
            values = [float(v) for v in fields[4:11]]
        except ValueError:
            raise MissionFileError(f"{where}: not numbers") from None
        if index != 0:
            rows.append(mission_row(frame, command, values, where))
    if not rows:
        raise MissionFileError("the file has no mission items after the home row")
    return rows


def read_mission_file(path: Path) -> list[MissionItem]:
    """A .plan or .waypoints (.txt) file's mission items."""
    readers = {".plan": read_plan, ".waypoints": read_waypoints, ".txt": read_waypoints}
    if path.suffix not in readers:
        raise MissionFileError("not a .plan or .waypoints file")
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise MissionFileError(f"cannot read it: {exc.strerror if isinstance(exc, OSError) else exc}") from None
    return readers[path.suffix](text)
