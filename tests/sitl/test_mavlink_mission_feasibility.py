"""A mission against the stored geofence, as PX4's MissionFeasibilityChecker judges it (docs/mavlink.md "Mission
feasibility"): the upload is accepted and kept as sent, "Geofence violation for waypoint N" is said, and the mission
is refused at start (MISSION_START DENIED, a switch to Mission TEMPORARILY_REJECTED, arming in Mission DENIED) until
the mission or the fence allows it. GF_MAX_HOR_DIST counts as the fence does. Lockstep, the default controller."""

from __future__ import annotations

from tests.sitl.ground_station import MissionClient
from tests.sitl.mavlink_sitl import start_sitl
from tests.sitl.test_mavlink_missions import REL, rows_of, same
from tests.sitl.test_mavlink_navigation import MISSION_MODE, latlon_e7, waypoint
from transport.mavlink import mavlink as M

FENCE = [(REL, M.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, 100.0, 0, 0, 0, *latlon_e7(0.0, 0.0), 0.0)]  # 100 m round home
INSIDE = [waypoint(0.0, 0.0, 10.0, M.MAV_CMD_NAV_TAKEOFF), waypoint(50.0, 0.0, 20.0),
          (M.MAV_FRAME_MISSION, M.MAV_CMD_NAV_RETURN_TO_LAUNCH, 0, 0, 0, 0, 0, 0, 0.0)]  # fmt: skip
OUTSIDE = [*INSIDE[0:2], waypoint(300.0, 0.0, 20.0), INSIDE[2]]  # its item 3 (counted from 1) is 300 m out


def test_a_mission_outside_the_fence_is_kept_but_refused_at_start(tmp_path):
    sitl = start_sitl(tmp_path / "params.json", speed=None)
    try:
        gs = sitl.gs
        gs.connect()
        client = MissionClient(gs)
        assert client.upload(M.MAV_MISSION_TYPE_FENCE, FENCE) == M.MAV_MISSION_ACCEPTED
        assert client.upload(M.MAV_MISSION_TYPE_MISSION, OUTSIDE) == M.MAV_MISSION_ACCEPTED  # as PX4
        said = lambda: client.statustexts + gs.statustexts  # noqa: E731 (the Client reads some of them)
        gs.wait(lambda: "Geofence violation for waypoint 3" in said(), "PX4's feasibility message")
        assert same(rows_of(client.download(M.MAV_MISSION_TYPE_MISSION)), OUTSIDE)  # kept as sent
        start = gs.command(M.MAV_CMD_MISSION_START, 0, 0)
        assert start.result == M.MAV_RESULT_DENIED
        assert gs.set_mode(MISSION_MODE).result == M.MAV_RESULT_TEMPORARILY_REJECTED
        gs.wait(lambda: {"Mission start denied! No valid mission",
                         "Switching to Mission is currently not available"} <= set(said()), "the reasons")  # fmt: skip
        # GF_MAX_HOR_DIST is part of the fence: 40 m makes the 50 m waypoint (item 2) of a fenced mission fail too.
        assert client.upload(M.MAV_MISSION_TYPE_MISSION, INSIDE) == M.MAV_MISSION_ACCEPTED
        gs.param_set("GF_MAX_HOR_DIST", 40.0, M.MAV_PARAM_TYPE_REAL32)
        assert gs.set_mode(MISSION_MODE).result == M.MAV_RESULT_TEMPORARILY_REJECTED
        gs.wait(lambda: "Geofence violation for waypoint 2" in said(), "the violation of GF_MAX_HOR_DIST")
        gs.param_set("GF_MAX_HOR_DIST", 0.0, M.MAV_PARAM_TYPE_REAL32)
        # Inside: Mission starts (on the ground it waits for arming), and the arming takes off into it; not while
        # the fence forbids it.
        assert gs.command(M.MAV_CMD_MISSION_START, 0, 0).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: gs.mode == MISSION_MODE, "Mission mode")
        gs.param_set("GF_MAX_HOR_DIST", 40.0, M.MAV_PARAM_TYPE_REAL32)
        assert gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == M.MAV_RESULT_DENIED
        gs.param_set("GF_MAX_HOR_DIST", 0.0, M.MAV_PARAM_TYPE_REAL32)
        assert gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: gs.altitude > 5.0, "the mission's takeoff", 60)
    finally:
        sitl.kill()
