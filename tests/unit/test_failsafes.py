"""PX4's failsafes in simulation time, without processes (docs/failsafes.md): the geofence's geometry, the offboard
loss action COM_OBL_RC_ACT, the data-link loss action NAV_DLL_ACT, the geofence action GF_ACTION, Return to the
closest of home and the rally points, and the sensor failures (what the plant sends, the GPS loss failsafe)."""

from __future__ import annotations

import math

import numpy as np
import pymap3d
import pytest

from aircraft.failures import Failure, FailureRejected, FailureType, FailureUnit
from autopilot.commander.commander import Commander, build_commander
from autopilot.commander.failsafe import Decision
from autopilot.commander.failsafe_reaction import Reaction, reaction
from autopilot.commander.guided_requests import GuidedRequests
from autopilot.navigator.geofence import breach, fence_from_items, inside_polygon
from autopilot.navigator.mission_feasibility import geofence_violation
from autopilot.navigator.modes.altitude import ALTITUDE
from autopilot.navigator.modes.hold import HOLD
from autopilot.navigator.modes.land import LAND
from autopilot.navigator.modes.offboard import OFFBOARD
from autopilot.navigator.modes.position import POSITION
from autopilot.navigator.modes.rtl import RETURN
from autopilot.navigator.return_route import (
    MissionLanding,
    closest_safe_point,
    mission_landing,
    return_destination,
    return_height,
)
from autopilot.storage.mission_store import MissionStore
from autopilot.storage.parameters import ParameterRejected, ParameterStore
from autopilot.topics.mission_items import MissionItem
from autopilot.topics.requests import ManualControlInput, Reposition
from autopilot.topics.vehicle_state import VehicleState
from transport.geodesy import Home
from transport.mavlink import mavlink as M

HOVER = 0.69
HOME = Home()
REL = M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT


def item(command: int, north: float, east: float, param1: float = 0.0, kind_z: float = 0.0) -> MissionItem:
    lat, lon, _ = pymap3d.ned2geodetic(north, east, 0.0, HOME.lat, HOME.lon, HOME.alt)
    return MissionItem(REL, command, 1, param1, 0.0, 0.0, 0.0, int(round(lat * 1e7)), int(round(lon * 1e7)), kind_z)


def state_at(t_s: float, north: float = 0.0, down: float = -50.0) -> VehicleState:
    state = VehicleState(time_usec=int(round(t_s * 1e6)), valid=True)
    state.position_ned[:] = (north, 0.0, down)
    return state


def flying_commander(missions: MissionStore | None = None, **params) -> tuple[Commander, list[str]]:
    store = ParameterStore(None)
    for name, value in params.items():
        store.set(name, value)
    said: list[str] = []
    commander = build_commander(store, HOVER, armed=True, in_air=True, say=lambda severity, text, key=None: said.append(text),
                          missions=missions, home=HOME)  # fmt: skip
    commander.start(state_at(0.0))
    return commander, said


def fly(commander: Commander, start_s: float, end_s: float, north: float = 0.0, every=None) -> None:
    t = start_s
    while t < end_s - 1e-9:
        t += 0.01
        if every is not None:
            every(t)
        commander.tick(state_at(t, north), int(round(t * 1e6)), HOVER)


# ---- the geofence's geometry ----------------------------------------------------------------------------------------
def test_polygons_and_circles_inclusion_and_exclusion_as_px4_combines_them():
    square = ((0.0, 0.0), (0.0, 100.0), (100.0, 100.0), (100.0, 0.0))
    assert inside_polygon(50.0, 50.0, square) and not inside_polygon(150.0, 50.0, square)
    vertex = M.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
    fence = fence_from_items(tuple(item(vertex, n, e, 4) for n, e in square) + (
        item(M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, 50.0, 50.0, 10.0),), HOME)  # fmt: skip
    assert len(fence.zones) == 2 and fence.ignored == ()
    assert breach(np.array([20.0, 20.0, -10.0]), fence, 0.0, 0.0) is None
    assert breach(np.array([52.0, 50.0, -10.0]), fence, 0.0, 0.0) == "inside exclusion zone 2"
    assert breach(np.array([120.0, 50.0, -10.0]), fence, 0.0, 0.0) == "outside every inclusion zone"
    assert "GF_MAX_HOR_DIST" in breach(np.array([20.0, 20.0, -10.0]), fence, 25.0, 0.0)
    assert "GF_MAX_VER_DIST" in breach(np.array([20.0, 20.0, -30.0]), fence, 0.0, 25.0)
    broken = fence_from_items((item(vertex, 0, 0, 4), item(vertex, 0, 10, 4)), HOME)
    assert broken.zones == () and "without all of them" in broken.ignored[0]


def test_return_goes_to_the_closest_of_home_and_the_rally_points():
    rally = [np.array([100.0, 0.0, 0.0]), np.array([0.0, -300.0, 0.0])]
    assert list(closest_safe_point(np.array([80.0, 0.0, -20.0]), rally)) == [100.0, 0.0]
    assert list(closest_safe_point(np.array([10.0, -100.0, -20.0]), rally)) == [0.0, 0.0]


def test_rtl_type_1_goes_to_the_closest_of_the_rally_points_and_the_mission_landing_home_only_without_them():
    home = np.zeros(3)
    here = np.array([80.0, 0.0, -20.0])
    rally = [np.array([100.0, 0.0, 0.0])]
    landing = MissionLanding(2, np.array([0.0, 60.0]))
    assert return_destination(0, here, rally, home, landing).tolist() == [100.0, 0.0]  # type 0: no mission landing
    assert return_destination(1, here, rally, home, landing).tolist() == [100.0, 0.0]  # 20 m against 100 m
    assert return_destination(1, np.array([10.0, 50.0, -20.0]), rally, home, landing) is landing
    assert return_destination(1, here, [], home, landing) is landing  # farther than home, still the landing
    assert return_destination(1, here, [], home, None).tolist() == [0.0, 0.0]  # neither: home
    # the landing: the first DO_LAND_START with a land item after it that has a position
    wp, land, start = M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_LAND, M.MAV_CMD_DO_LAND_START
    rows = [mission_row(wp, 1), mission_row(land, 2), mission_row(start, 0), mission_row(wp, 3),
            mission_row(M.MAV_CMD_NAV_VTOL_LAND, 4)]  # fmt: skip

    def place(it: MissionItem) -> np.ndarray | None:
        return None if it.x == 0 else np.array([float(it.x), 0.0, 0.0])

    found = mission_landing(tuple(rows), place)
    assert found is not None and found.start_seq == 2 and found.point.tolist() == [4.0, 0.0]
    assert mission_landing(tuple(rows[:2]), place) is None  # no DO_LAND_START
    assert mission_landing((rows[2], rows[3]), place) is None  # no land after it
    assert mission_landing((rows[2], mission_row(land, 0)), place) is None  # a land "here" has no place to go to


def mission_row(command: int, x: int) -> MissionItem:
    frame = M.MAV_FRAME_MISSION if command == M.MAV_CMD_DO_LAND_START else M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    return MissionItem(frame, command, 1, 0.0, 0.0, 0.0, 0.0, x, 0 if x == 0 else 1, 10.0)


def test_return_altitude_follows_px4_s_rule_rtl_min_dist_and_rtl_cone_ang():
    # (height now, distance, RTL_RETURN_ALT, RTL_CONE_ANG, RTL_MIN_DIST, NAV_ACC_RAD)
    assert return_height(10.0, 500.0, 60.0, 45, 100.0, 10.0) == 60.0  # beyond RTL_MIN_DIST: RTL_RETURN_ALT
    assert math.isclose(return_height(10.0, 30.0, 60.0, 45, 100.0, 10.0), 30.0)  # within: the 45 deg cone's height
    assert return_height(10.0, 30.0, 60.0, 45, 20.0, 10.0) == 60.0  # the cone only within RTL_MIN_DIST
    assert return_height(2.0, 30.0, 60.0, 80, 100.0, 10.0) == 20.0  # a narrow cone: at least 2 x NAV_ACC_RAD
    assert math.isclose(return_height(2.0, 30.0, 60.0, 80, 100.0, 1.0), 30.0 / math.tan(math.radians(80)))
    assert return_height(2.0, 4.0, 60.0, 45, 100.0, 10.0) == 8.0  # within NAV_ACC_RAD: twice the distance
    assert return_height(40.0, 30.0, 60.0, 45, 100.0, 10.0) == 40.0  # above the cone: no descent
    assert return_height(10.0, 30.0, 60.0, 0, 100.0, 10.0) == 60.0  # 0: no cone
    assert return_height(2.0, 30.0, 15.0, 10, 100.0, 10.0) == 15.0  # never above RTL_RETURN_ALT
    assert return_height(70.0, 500.0, 60.0, 45, 100.0, 10.0) == 70.0  # above RTL_RETURN_ALT: stays


# ---- the actions, through the commander -------------------------------------------------------------------------------
@pytest.mark.parametrize("action, mode, sticks", [(0, HOLD, False), (1, HOLD, False), (2, HOLD, True),
                                                  (0, POSITION, True), (1, ALTITUDE, True), (3, RETURN, False),
                                                  (4, LAND, False), (5, HOLD, False)])  # fmt: skip
def test_offboard_loss_takes_com_obl_rc_act(action, mode, sticks):
    """Position and Altitude need MANUAL_CONTROL (heard within COM_RC_LOSS_T): without it, Hold, as PX4 falls back."""
    commander, said = flying_commander(COM_OBL_RC_ACT=action)
    centred = (lambda t: commander.manual_control(ManualControlInput())) if sticks else None
    commander.offboard.receive(np.array([1.0, 0.0, 0.0]), None, commander.now_usec)
    assert commander.set_mode(OFFBOARD, state_at(0.0))[0] == M.MAV_RESULT_ACCEPTED
    fly(commander, 0.0, 1.1, every=centred)
    assert commander.mode == mode and f"Failsafe activated: {mode}" in said
    assert any(text.startswith("Offboard lost") for text in said)


def test_px4_actions_that_need_rc_or_kill_the_vehicle_are_refused_as_parameter_values():
    store = ParameterStore(None)
    for name, value in (("COM_OBL_RC_ACT", 6), ("NAV_DLL_ACT", 5), ("GF_ACTION", 6), ("COM_DL_LOSS_T", 1)):
        with pytest.raises(ParameterRejected):
            store.set(name, value)


def test_data_link_loss_after_com_dl_loss_t_takes_nav_dll_act_and_is_said_when_regained():
    commander, said = flying_commander(NAV_DLL_ACT=2, COM_DL_LOSS_T=5)
    fly(commander, 0.0, 20.0)
    assert commander.mode == HOLD  # no ground station heard yet: no link to lose
    commander.failsafe.gcs_heartbeat(commander.now_usec)
    fly(commander, 20.0, 25.0)
    assert commander.mode == HOLD
    fly(commander, 25.0, 25.02)
    assert commander.mode == RETURN and "Connection to ground station lost" in " ".join(said)
    commander.failsafe.gcs_heartbeat(commander.now_usec)
    assert said[-1] == "Data link regained"
    landing, _ = flying_commander(NAV_DLL_ACT=2, COM_DL_LOSS_T=5)
    landing.failsafe.gcs_heartbeat(0)
    GuidedRequests(landing).land(state_at(0.0))
    fly(landing, 0.0, 6.0)
    assert landing.mode == LAND  # PX4 ignores the data-link loss while landing


def test_geofence_breach_takes_gf_action_once_and_return_heads_for_the_closest_rally_point():
    missions = MissionStore()
    missions.store(M.MAV_MISSION_TYPE_RALLY, (item(M.MAV_CMD_NAV_RALLY_POINT, 90.0, 0.0),))
    commander, said = flying_commander(missions, GF_MAX_HOR_DIST=100.0, GF_ACTION=3)
    fly(commander, 0.0, 1.0, north=99.0)
    assert commander.mode == HOLD
    fly(commander, 1.0, 1.02, north=101.0)
    assert commander.mode == RETURN and any("beyond GF_MAX_HOR_DIST 100 m" in text for text in said)
    route = commander.modes[RETURN].auto.route
    assert math.hypot(*(route[-1].xy - np.array([90.0, 0.0]))) < 0.01  # lands at the rally point
    commander.set_mode(HOLD, state_at(1.02, 101.0))
    fly(commander, 1.02, 2.0, north=101.0)
    assert commander.mode == HOLD  # still outside, but the breach acted once: the user flies out of it
    going, said = flying_commander(GF_MAX_HOR_DIST=100.0)  # GF_ACTION 2: Hold
    go_to = Reposition(np.array([200.0, 0.0, -50.0]), None)
    assert GuidedRequests(going).route(go_to, state_at(0.0))[0] == M.MAV_RESULT_ACCEPTED
    fly(going, 0.0, 0.1, north=101.0)
    assert going.mode == HOLD and not going.navigator.hold.repositioning  # the Go-to stops where the fence is
    assert "Failsafe activated: Hold" in said
    warn, said = flying_commander(GF_MAX_VER_DIST=40.0, GF_ACTION=1)
    fly(warn, 0.0, 0.1)
    assert warn.mode == HOLD and any("GF_MAX_VER_DIST" in text for text in said)
    fenced = MissionStore()
    fenced.store(M.MAV_MISSION_TYPE_FENCE, (item(M.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, 500.0, 0.0, 50.0),))
    store = ParameterStore(None)
    on_ground = build_commander(store, HOVER, armed=False, in_air=False, missions=fenced, home=HOME)
    on_ground.start(state_at(0.0, down=0.0))
    result, reason = on_ground.arm(state_at(0.0, down=0.0))
    assert result == M.MAV_RESULT_DENIED and "outside the geofence" in reason  # PX4's pre-arm check
    store.set("GF_ACTION", 0)
    assert on_ground.arm(state_at(0.0, down=0.0))[0] == M.MAV_RESULT_ACCEPTED
    terminate, said = flying_commander(GF_MAX_VER_DIST=40.0, GF_ACTION=4)
    fly(terminate, 0.0, 0.1)
    assert not terminate.armed and terminate.terminated and any("flight termination" in text for text in said)
    home = terminate.homes.position
    falling = state_at(0.2, down=-45.0)
    falling.velocity_ned[:] = (0.0, 0.0, 8.0)
    terminate.tick(falling, falling.time_usec, 0.0)
    assert terminate.homes.position is home  # home does not follow a falling vehicle
    at_rest = state_at(3.0, north=5.0, down=0.0)
    terminate.tick(at_rest, at_rest.time_usec, 0.0)
    assert terminate.homes.position.ned[0] == 5.0  # at rest on the ground, it does


# ---- sensor failures ----------------------------------------------------------------------------------------------------
def test_a_failed_sensor_leaves_the_plant_s_messages_and_a_failed_gps_sends_no_hil_gps(airframe):
    from sim_bridge.plant import Plant, Spawn
    from sim_bridge.sensors import GPS_PERIOD_USEC, SensorSuite
    from transport.geodesy import LocalGeodetic
    from transport.mavlink import Link

    plant = Plant(airframe, Spawn(altitude=20.0), compile_model=False)
    suite = SensorSuite(plant, Link(1, 200), LocalGeodetic(HOME))
    reader = Link(255, 190)

    def kinds() -> dict:
        return {message.get_type(): message for message in reader.parse(suite.datagram())}

    assert plant.time_usec % GPS_PERIOD_USEC == 0 and {"HIL_GPS", "HIL_SENSOR"} <= set(kinds())
    assert plant.inject_failure(4, 1, 0, math.nan) == ["GPS all OFF"]
    plant.inject_failure(3, 1, 1, math.nan)  # baro
    sent = kinds()
    assert "HIL_GPS" not in sent and "HIL_STATE_QUATERNION" in sent  # the truth still goes out
    assert sent["HIL_SENSOR"].fields_updated == 0x1FFF & ~0x1A00 and sent["HIL_SENSOR"].abs_pressure == 0.0
    plant.inject_failure(4, 0, 0, math.nan)
    assert "HIL_GPS" in kinds()
    with pytest.raises(FailureRejected):
        plant.inject_failure(4, 2, 1, math.nan)  # STUCK is not simulated for sensors


def test_gps_loss_in_the_air_descends_after_com_pos_fs_delay_and_position_modes_are_refused():
    commander, said = flying_commander(COM_POS_FS_DELAY=2)
    commander.failsafe.failure_known(Failure(FailureUnit.GPS, FailureType.OFF, 0))
    fly(commander, 0.0, 1.9)
    assert commander.mode == HOLD and "GPS lost: no position estimate" in said
    fly(commander, 1.9, 2.1)
    assert commander.mode == LAND and "Failsafe activated: Descend" in said
    setpoint = commander.tick(state_at(2.2), 2_200_000, HOVER)
    assert list(setpoint[0:2]) == [0.0, 0.0]  # no horizontal position control
    result, reason = commander.set_mode(HOLD, state_at(2.2))
    assert result == M.MAV_RESULT_TEMPORARILY_REJECTED and "GPS lost" in reason
    commander.failsafe.failure_known(Failure(FailureUnit.GPS, FailureType.OK, 0))
    assert commander.set_mode(HOLD, state_at(2.2))[0] == M.MAV_RESULT_ACCEPTED


def test_a_failsafe_decision_becomes_px4_s_plan():
    cause = "Geofence violated: x"
    assert reaction(Decision("Warn", cause), HOLD, True) == Reaction(before=((M.MAV_SEVERITY_WARNING, cause),))
    assert reaction(Decision(RETURN, cause), LAND, True).mode is None  # not Return while landing
    descend = reaction(Decision("Descend", cause), HOLD, True)
    assert (descend.mode, descend.descend, descend.after) == (
        LAND,
        True,
        ((M.MAV_SEVERITY_CRITICAL, "Failsafe activated: Descend"),),
    )
    terminate, disarm = (
        reaction(Decision("Terminate", cause), HOLD, True),
        reaction(Decision("Disarm", cause), HOLD, True),
    )
    assert terminate.cut_motors is not None and terminate.terminate  # the motors stay off until cleared
    assert disarm.cut_motors is not None and not disarm.terminate  # NAV_RCL_ACT 6: a disarm, no termination
    again = reaction(Decision(HOLD, cause), HOLD, False)  # Hold again stops a Go-to; nothing activated on the ground
    assert again.mode == HOLD and again.before == ((M.MAV_SEVERITY_WARNING, f"{cause}, Hold"),) and again.after == ()


def test_only_mission_items_with_a_position_are_checked_against_the_fence():
    items = (item(M.MAV_CMD_NAV_WAYPOINT, 10.0, 0.0), item(M.MAV_CMD_NAV_WAYPOINT, 500.0, 0.0),
             MissionItem(REL, M.MAV_CMD_NAV_LAND, 1, 0.0, 0.0, 0.0, 0.0, 0, 0, 0.0))  # fmt: skip
    positions = {id(items[0]): np.array([10.0, 0.0, 0.0]), id(items[1]): np.array([500.0, 0.0, 0.0])}  # land: none

    def far(ned: np.ndarray) -> str | None:
        return "beyond 100 m" if ned[0] > 100.0 else None

    assert geofence_violation(items, lambda it: positions.get(id(it)), far) == "Geofence violation for waypoint 2"
    assert geofence_violation(items[0:1] + items[2:], lambda it: positions.get(id(it)), far) is None
