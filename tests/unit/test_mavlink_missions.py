"""The mission protocol (issue 11 item 1, docs/missions.md): uploads and downloads of missions, fences and
rally points through the real processes, clear, current item, persistence across a restart, bad input refused with
PX4's MISSION_ACK results and the stored lists left intact, an abandoned upload."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from autopilot.navigator.mission_feasibility import geofence_violation
from autopilot.navigator.mission_flight import region_of_interest
from autopilot.storage.mission_store import MissionFileError, MissionStore, document, parse_document
from autopilot.topics.mission_items import PAYLOAD, MissionItem, check_item
from transport.mavlink import mavlink as M

LAT, LON = 473977420, 85455940
REL = M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT

# (frame, command, p1, p2, p3, p4, x, y, z)
SURVEY = [
    (REL, M.MAV_CMD_NAV_VTOL_TAKEOFF, 0, 0, 0, math.nan, LAT, LON, 30.0),
    (REL, M.MAV_CMD_NAV_WAYPOINT, 0, 10, 0, math.nan, LAT + 36000, LON, 40.0),
    (M.MAV_FRAME_MISSION, M.MAV_CMD_DO_CHANGE_SPEED, 1, 20, -1, 0, 0, 0, 0),
    (M.MAV_FRAME_MISSION, M.MAV_CMD_DO_VTOL_TRANSITION, 4, 0, 0, 0, 0, 0, 0),
    (M.MAV_FRAME_GLOBAL_INT, M.MAV_CMD_NAV_LOITER_TIME, 5, 0, 80, 0, LAT + 36000, LON + 54000, 528.0),
    (M.MAV_FRAME_MISSION, M.MAV_CMD_DO_JUMP, 1, 2, 0, 0, 0, 0, 0),
    (M.MAV_FRAME_MISSION, M.MAV_CMD_NAV_DELAY, 3, -1, -1, -1, 0, 0, 0),
    (M.MAV_FRAME_MISSION, M.MAV_CMD_NAV_RETURN_TO_LAUNCH, 0, 0, 0, 0, 0, 0, 0),
    (REL, M.MAV_CMD_NAV_VTOL_LAND, 0, 0, 0, math.nan, LAT, LON, 0.0),
]
FENCE = [(REL, M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, 3, 0, 0, 0, LAT + d[0], LON + d[1], 0.0)
         for d in ((-9000, -9000), (9000, -9000), (9000, 9000))] + [
        (REL, M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, 50, 0, 0, 0, LAT + 3000, LON, 0.0)]  # fmt: skip
RALLY = [(REL, M.MAV_CMD_NAV_RALLY_POINT, 0, 0, 0, 0, LAT + 1000, LON - 2000, 20.0)]
TYPES = {M.MAV_MISSION_TYPE_MISSION: SURVEY, M.MAV_MISSION_TYPE_FENCE: FENCE, M.MAV_MISSION_TYPE_RALLY: RALLY}


def item(row: tuple) -> MissionItem:
    frame, command, p1, p2, p3, p4, x, y, z = row
    return MissionItem(frame, command, 1, float(p1), float(p2), float(p3), float(p4), x, y, float(z))


# ---- pure checks and the file -----------------------------------------------------------------------------------------
BAD_ITEMS = [
    ("unknown command", (REL, 31337, 0, 0, 0, 0, LAT, LON, 10.0), M.MAV_MISSION_UNSUPPORTED),
    ("DO_ item in a global frame", (REL, M.MAV_CMD_DO_JUMP, 1, 1, 0, 0, LAT, LON, 0.0), M.MAV_MISSION_UNSUPPORTED),
    ("local frame", (M.MAV_FRAME_LOCAL_NED, M.MAV_CMD_NAV_WAYPOINT, 0, 0, 0, 0, 0, 0, 10.0),
     M.MAV_MISSION_UNSUPPORTED_FRAME),
    ("waypoint in MISSION frame", (M.MAV_FRAME_MISSION, M.MAV_CMD_NAV_WAYPOINT, 0, 0, 0, 0, 0, 0, 10.0),
     M.MAV_MISSION_UNSUPPORTED_FRAME),
    ("latitude beyond 90", (REL, M.MAV_CMD_NAV_WAYPOINT, 0, 0, 0, 0, 900_000_001, LON, 10.0),
     M.MAV_MISSION_INVALID_PARAM5_X),
    ("longitude beyond 180", (REL, M.MAV_CMD_NAV_WAYPOINT, 0, 0, 0, 0, LAT, -1_800_000_001, 10.0),
     M.MAV_MISSION_INVALID_PARAM6_Y),
    ("NaN altitude", (REL, M.MAV_CMD_NAV_WAYPOINT, 0, 0, 0, 0, LAT, LON, math.nan), M.MAV_MISSION_INVALID_PARAM7),
    ("infinite param2", (REL, M.MAV_CMD_NAV_WAYPOINT, 0, math.inf, 0, 0, LAT, LON, 10.0),
     M.MAV_MISSION_INVALID_PARAM2),
    ("fence item in a mission", FENCE[0], M.MAV_MISSION_ERROR),
    ("camera item in a global frame", (REL, M.MAV_CMD_IMAGE_START_CAPTURE, 0, 1, 0, 0, LAT, LON, 0.0),
     M.MAV_MISSION_UNSUPPORTED),
    ("ROI location in MISSION frame", (M.MAV_FRAME_MISSION, M.MAV_CMD_DO_SET_ROI_LOCATION, 0, 0, 0, 0, 0, 0, 0.0),
     M.MAV_MISSION_UNSUPPORTED_FRAME),
    ("DO_SET_ROI WPNEXT with a position", (REL, M.MAV_CMD_DO_SET_ROI, M.MAV_ROI_WPNEXT, 0, 0, 0, LAT, LON, 0.0),
     M.MAV_MISSION_INVALID_PARAM1),
    ("DO_SET_ROI LOCATION without one", (M.MAV_FRAME_MISSION, M.MAV_CMD_DO_SET_ROI, M.MAV_ROI_LOCATION, 0, 0, 0, 0, 0,
                                         0.0), M.MAV_MISSION_INVALID_PARAM1),
    ("DO_SET_ROI NaN mode", (M.MAV_FRAME_MISSION, M.MAV_CMD_DO_SET_ROI, math.nan, 0, 0, 0, 0, 0, 0.0),
     M.MAV_MISSION_INVALID_PARAM1),
]  # fmt: skip


@pytest.mark.parametrize("why, row, result", BAD_ITEMS, ids=[case[0] for case in BAD_ITEMS])
def test_bad_items_get_px4s_result(why, row, result):
    assert check_item(M.MAV_MISSION_TYPE_MISSION, item(row)) == result


def test_supported_items_pass_and_fence_polygons_need_three_vertices():
    for kind, rows in TYPES.items():
        assert all(check_item(kind, item(row)) == M.MAV_MISSION_ACCEPTED for row in rows)
    two = item((REL, M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, 2, 0, 0, 0, LAT, LON, 0.0))
    assert check_item(M.MAV_MISSION_TYPE_FENCE, two) == M.MAV_MISSION_ERROR
    assert check_item(M.MAV_MISSION_TYPE_RALLY, item(SURVEY[1])) == M.MAV_MISSION_ERROR
    zero = item((REL, M.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, 0, 0, 0, 0, 0, 0, 0.0))  # MAVSDK's geofence example
    assert check_item(M.MAV_MISSION_TYPE_FENCE, zero) == M.MAV_MISSION_ACCEPTED
    # PX4's payload and region-of-interest items (QGroundControl's camera sections)
    payload = [(M.MAV_FRAME_MISSION, command, 0, 0, 0, 0, 0, 0, 0.0) for command in sorted(PAYLOAD)]
    roi = [(REL, M.MAV_CMD_DO_SET_ROI_LOCATION, 0, 0, 0, 0, LAT, LON, 0.0),
           (REL, M.MAV_CMD_DO_SET_ROI, M.MAV_ROI_LOCATION, 0, 0, 0, LAT, LON, 0.0),
           (M.MAV_FRAME_MISSION, M.MAV_CMD_DO_SET_ROI, M.MAV_ROI_WPNEXT, 0, 0, 0, 0, 0, 0.0),
           (M.MAV_FRAME_MISSION, M.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET, 0, 0, 0, 0, 0, 0, 30.0),
           (M.MAV_FRAME_MISSION, M.MAV_CMD_DO_SET_ROI_NONE, 0, 0, 0, 0, 0, 0, 0.0)]  # fmt: skip
    assert len(payload) == 19  # with DO_LAND_START, the 20 MAV_FRAME_MISSION commands PX4 passes at once
    assert all(check_item(M.MAV_MISSION_TYPE_MISSION, item(row)) == M.MAV_MISSION_ACCEPTED for row in payload + roi)


def test_a_region_of_interest_is_the_point_or_the_next_item_and_not_a_waypoint_for_the_geofence():
    here = np.array([5.0, 6.0, -20.0])
    at = region_of_interest(item((REL, M.MAV_CMD_DO_SET_ROI_LOCATION, 0, 0, 0, 0, LAT, LON, 0.0)), lambda _: here)
    assert at is not None and at.xy.tolist() == [5.0, 6.0]
    offset = region_of_interest(item((M.MAV_FRAME_MISSION, M.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET, 0, 0, 0, 0, 0, 0,
                                      30.0)), lambda _: here)  # fmt: skip
    assert offset is not None and offset.xy is None and math.isclose(offset.yaw_offset, math.radians(30.0))
    nan_offset = region_of_interest(item((M.MAV_FRAME_MISSION, M.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET, 0, 0, 0, 0, 0, 0,
                                          math.nan)), lambda _: here)  # fmt: skip
    assert nan_offset is not None and nan_offset.yaw_offset == 0.0  # NaN: MAVLink's default, no offset
    for row in ((M.MAV_FRAME_MISSION, M.MAV_CMD_DO_SET_ROI_NONE, 0, 0, 0, 0, 0, 0, 0.0),
                (M.MAV_FRAME_MISSION, M.MAV_CMD_DO_SET_ROI, M.MAV_ROI_WPINDEX, 2, 0, 0, 0, 0, 0.0),
                (REL, M.MAV_CMD_DO_SET_ROI, M.MAV_ROI_NONE, 0, 0, 0, LAT, LON, 0.0)):  # fmt: skip
        assert region_of_interest(item(row), lambda _: here) is None
    # a region of interest beyond the fence is no violation: only the points flown to are checked (as PX4)
    far = LON + 1_000_000

    def position_of(it: MissionItem) -> np.ndarray:
        return np.array([10.0, 50_000.0 if it.y == far else 0.0, -10.0])

    def outside(ned: np.ndarray) -> str | None:
        return "beyond 100 m" if ned[1] > 100.0 else None

    near_waypoint = item((REL, M.MAV_CMD_NAV_WAYPOINT, 0, 0, 0, 0, LAT, LON, 10.0))
    far_roi = item((REL, M.MAV_CMD_DO_SET_ROI_LOCATION, 0, 0, 0, 0, LAT, far, 0.0))
    far_waypoint = item((REL, M.MAV_CMD_NAV_WAYPOINT, 0, 0, 0, 0, LAT, far, 10.0))
    assert geofence_violation((far_roi, near_waypoint), position_of, outside) is None
    assert (
        geofence_violation((near_waypoint, far_waypoint), position_of, outside) == "Geofence violation for waypoint 2"
    )
    negative = item((REL, M.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, -5, 0, 0, 0, LAT, LON, 0.0))
    assert check_item(M.MAV_MISSION_TYPE_FENCE, negative) == M.MAV_MISSION_INVALID_PARAM1


def test_the_mission_file_round_trips_and_broken_ones_are_refused(tmp_path):
    store = MissionStore(tmp_path / "missions-0.json")
    for kind, rows in TYPES.items():
        store.store(kind, tuple(item(r) for r in rows), current=2 if kind == M.MAV_MISSION_TYPE_MISSION else 0)
    assert store.flush() is None
    again = MissionStore(store.path)
    again.load()
    assert again.snapshot.mission == store.snapshot.mission and again.snapshot.fence == store.snapshot.fence
    assert again.snapshot.rally == store.snapshot.rally and again.snapshot.current == 2
    good = json.loads(document(store.snapshot))
    broken = [
        "{", json.dumps({**good, "format": "x"}), json.dumps({**good, "version": 2}),
        json.dumps({**good, "current": 99}), json.dumps({**good, "mission": [{"frame": 3}]}),
        json.dumps({**good, "fence": good["mission"]}),
        json.dumps({**good, "mission": [{**good["mission"][1], "command": 31337}]}),
    ]  # fmt: skip
    for text in broken:
        with pytest.raises(MissionFileError):
            parse_document(text, "test file")
