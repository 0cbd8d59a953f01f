"""The stored mission, geofence and rally points, and the mission's progress: what the flight stack keeps, the
mission protocol changes (through typed requests) and the navigator will fly.

`MissionStore.snapshot` is an immutable `Missions`: the three item lists (tuples of `MissionItem`), the current
sequence number, the mission state and the last item reached. Every change replaces the snapshot, so a reader
(the VehicleStatus carries it each step, the navigator reads it) never sees a half-made change.

The interface the navigator flies missions with:

    store.snapshot.mission, .fence, .rally      the items (autopilot/topics/mission_items.py)
    store.snapshot.current, .state              where the mission stands (MISSION_CURRENT)
    store.set_progress(current, state)          the navigator moved on (MISSION_STATE_ACTIVE, _PAUSED, _COMPLETE)
    store.reached(seq)                          an item was reached (MISSION_ITEM_REACHED goes out)
    store.version                               changes with every new item list or current item

The file (missions-<instance>.json next to the parameter file) holds the three lists and the current item:

    {"format": "tiltrotor-sitl missions", "version": 1, "current": 0,
     "mission": [{"frame": 3, "command": 16, "autocontinue": 1, "params": [0, 10, 0, null], "x": 473977420,
                  "y": 85455940, "z": 30.0}, ...], "fence": [...], "rally": [...]}

(NaN parameters are written as null.) It is written atomically on a background thread, like the parameter file,
and read at start: a broken file is refused (MissionFileError), never half-used.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

from autopilot.storage.kept_file import BackgroundWriter, read_kept
from autopilot.topics.mission_items import (
    FENCE,
    MAX_ITEMS,
    MISSION,
    RALLY,
    TYPE_NAMES,
    MissionItem,
    check_item,
    result_name,
)
from autopilot.topics.missions import EMPTY, Missions
from transport.mavlink import mavlink as M

FILE_FORMAT = "tiltrotor-sitl missions"
FILE_VERSION = 1


class MissionFileError(ValueError):
    """The mission file cannot be used (not JSON, wrong shape, an item this vehicle refuses)."""


def default_mission_path(parameter_path: Path, instance: int) -> Path:
    """missions-<instance>.json in the parameter file's folder."""
    return parameter_path.parent / f"missions-{instance}.json"


def initial_state(mission: tuple[MissionItem, ...]) -> int:
    return M.MISSION_STATE_NOT_STARTED if mission else M.MISSION_STATE_NO_MISSION


class MissionStore:
    def __init__(self, path: Path | None = None) -> None:
        self.path = path
        self.snapshot = EMPTY
        self.version = 0
        self._writer = BackgroundWriter(path, "mission file") if path is not None else None

    # ---- changes (the flight stack makes them from the protocol's requests; the navigator from its progress) ------
    def store(self, mission_type: int, items: tuple[MissionItem, ...], current: int = 0) -> None:
        """Replace one list (checked by the protocol already); a new mission starts at `current`, not started."""
        s = self.snapshot
        if mission_type == MISSION:
            current = current if 0 <= current < len(items) else 0
            self.snapshot = replace(s, mission=items, current=current, state=initial_state(items), reached=-1)
        elif mission_type == FENCE:
            self.snapshot = replace(s, fence=items)
        else:
            self.snapshot = replace(s, rally=items)
        self._changed()

    def clear(self, mission_type: int) -> None:
        """One list, or all three for MAV_MISSION_TYPE_ALL."""
        for kind in (MISSION, FENCE, RALLY) if mission_type == M.MAV_MISSION_TYPE_ALL else (mission_type,):
            self.store(kind, ())

    def set_current(self, seq: int) -> bool:
        """The next mission item to fly; False when there is no such item."""
        if not 0 <= seq < len(self.snapshot.mission):
            return False
        if seq != self.snapshot.current:
            self.snapshot = replace(self.snapshot, current=seq)
            self._changed()
        return True

    def set_progress(self, current: int, state: int) -> None:
        """The navigator's: where the mission stands (not persisted beyond the current item)."""
        self.set_current(current)
        if state != self.snapshot.state:
            self.snapshot = replace(self.snapshot, state=state)

    def reached(self, seq: int) -> None:
        self.snapshot = replace(self.snapshot, reached=seq, reached_count=self.snapshot.reached_count + 1)

    def _changed(self) -> None:
        self.version += 1
        if self._writer is not None:
            self._writer.submit(document(self.snapshot))

    # ---- persistence -----------------------------------------------------------------------------------------------
    @property
    def write_error(self) -> str | None:
        return None if self._writer is None else self._writer.last_error

    def flush(self, timeout_s: float = 10.0) -> str | None:
        return None if self._writer is None else self._writer.flush(timeout_s)

    def load(self) -> None:
        """Read the file if there is one (none: nothing stored); MissionFileError if it is broken."""
        if self.path is None:
            return
        text = read_kept(self.path, "mission file", MissionFileError)
        if text is None:
            return
        self.snapshot = parse_document(text, f"mission file {self.path}")


def _item_json(item: MissionItem) -> dict[str, Any]:
    params = [None if math.isnan(p) else p for p in (item.param1, item.param2, item.param3, item.param4)]
    return {"frame": item.frame, "command": item.command, "autocontinue": item.autocontinue, "params": params,
            "x": item.x, "y": item.y, "z": None if math.isnan(item.z) else item.z}  # fmt: skip


def document(missions: Missions) -> str:
    return json.dumps({"format": FILE_FORMAT, "version": FILE_VERSION, "current": missions.current,
                       **{TYPE_NAMES[kind]: [_item_json(i) for i in missions.items(kind)] for kind in TYPE_NAMES}},
                      indent=1, allow_nan=False) + "\n"  # fmt: skip


def _number(value: Any, where: str, *, nullable: bool) -> float:
    if value is None and nullable:
        return math.nan
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise MissionFileError(f"{where}: {value!r} is not a number")
    return float(value)


def _integer(value: Any, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise MissionFileError(f"{where}: {value!r} is not an integer")
    return value


def _parse_item(entry: Any, mission_type: int, where: str) -> MissionItem:
    if not isinstance(entry, dict) or set(entry) != {"frame", "command", "autocontinue", "params", "x", "y", "z"}:
        raise MissionFileError(f"{where}: expected an object with frame, command, autocontinue, params, x, y, z")
    params = entry["params"]
    if not isinstance(params, list) or len(params) != 4:
        raise MissionFileError(f"{where}: params must be a list of 4 numbers (null for NaN)")
    p1, p2, p3, p4 = (_number(p, where, nullable=True) for p in params)
    item = MissionItem(_integer(entry["frame"], where), _integer(entry["command"], where),
                       _integer(entry["autocontinue"], where), p1, p2, p3, p4, _integer(entry["x"], where),
                       _integer(entry["y"], where), _number(entry["z"], where, nullable=True))  # fmt: skip
    result = check_item(mission_type, item)
    if result != M.MAV_MISSION_ACCEPTED:
        raise MissionFileError(f"{where}: refused ({result_name(result)})")
    return item


def parse_document(text: str, where: str) -> Missions:
    try:
        data = json.loads(text)
    except ValueError as exc:
        raise MissionFileError(f"{where} is not valid JSON ({exc})") from None
    if not isinstance(data, dict) or data.get("format") != FILE_FORMAT:
        raise MissionFileError(f'{where}: not a tiltrotor-sitl mission file (no "format": "{FILE_FORMAT}")')
    if data.get("version") != FILE_VERSION:
        raise MissionFileError(f"{where}: version {data.get('version')!r}, expected {FILE_VERSION}")
    lists: dict[int, tuple[MissionItem, ...]] = {}
    for kind, name in TYPE_NAMES.items():
        entries = data.get(name, [])
        if not isinstance(entries, list) or len(entries) > MAX_ITEMS[kind]:
            raise MissionFileError(f'{where}: "{name}" must be a list of at most {MAX_ITEMS[kind]} items')
        lists[kind] = tuple(_parse_item(e, kind, f"{where}: {name} item {i}") for i, e in enumerate(entries))
    current = _integer(data.get("current", 0), f"{where}: current")
    if lists[MISSION] and not 0 <= current < len(lists[MISSION]) or not lists[MISSION] and current != 0:
        raise MissionFileError(f"{where}: current {current} is not an item of the mission")
    return Missions(lists[MISSION], lists[FENCE], lists[RALLY], current, initial_state(lists[MISSION]))
