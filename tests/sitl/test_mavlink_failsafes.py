"""PX4's failsafes through MAVLink (docs/failsafes.md), in lockstep with the unified MPC: offboard loss takes
COM_OBL_RC_ACT (Land, then Return), a silent ground station takes NAV_DLL_ACT, and flying past GF_MAX_HOR_DIST takes
GF_ACTION = Return, which lands at the rally point closer than home."""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager

from autopilot.storage.parameters import BY_NAME, encode_value
from tests.sitl.ground_station import HOLD, LAND, OFFBOARD, MissionClient, said
from tests.sitl.mavlink_sitl import start_sitl
from tests.sitl.test_mavlink_navigation import RETURN_MODE, latlon_e7
from tiltrotor_sitl import Controller
from transport.geodesy import Home
from transport.mavlink import mavlink as M

HOME = Home()
REL = M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT


def set_param(gs, name: str, value: float) -> None:
    definition = BY_NAME[name]
    kind = M.MAV_PARAM_TYPE_INT32 if definition.kind == "INT32" else M.MAV_PARAM_TYPE_REAL32
    assert gs.param_set(name, encode_value(definition, value), kind).param_value == encode_value(definition, value)


@contextmanager
def hovering(tmp_path, altitude: float = 20.0, controller: Controller = "mpc") -> Iterator:
    """A vehicle spawned hovering over home, in lockstep (with the MPC by default); its connected ground station."""
    sitl = start_sitl(tmp_path / "params.json", spawn_alt=altitude, speed=None, controller=controller)
    try:
        sitl.gs.connect()
        yield sitl.gs
    finally:
        sitl.kill()


def test_offboard_loss_lands_or_returns_as_com_obl_rc_act_says(tmp_path):
    with hovering(tmp_path) as gs:

        def stream() -> None:
            gs.velocity_setpoint(0.0, 0.0, 0.0)

        for action, mode, name in ((4, LAND, "Land"), (3, RETURN_MODE, "Return")):
            set_param(gs, "COM_OBL_RC_ACT", action)
            stream()
            gs.pump(0.02)
            assert gs.set_mode(OFFBOARD).result == M.MAV_RESULT_ACCEPTED
            gs.wait(lambda: gs.mode == OFFBOARD, "Offboard", every=stream)
            gs.wait_sim(1.0, every=stream)
            stopped = gs.sim_time
            gs.wait(lambda: gs.mode == mode, f"the offboard loss failsafe to custom mode {mode:#x}", timeout_s=30)
            assert gs.sim_time - stopped <= 1.0 + 0.15  # COM_OF_LOSS_T
            gs.wait(lambda: f"Failsafe activated: {name}" in gs.statustexts, "the failsafe's STATUSTEXT")
            assert gs.armed and gs.altitude > 15.0
        assert sum("Offboard lost" in text for text in gs.statustexts) == 2


def test_a_silent_ground_station_triggers_nav_dll_act_and_the_regained_link_is_said(tmp_path):
    with hovering(tmp_path) as gs:
        set_param(gs, "COM_DL_LOSS_T", 5)
        set_param(gs, "NAV_DLL_ACT", 3)  # Land
        gs.wait_sim(2.0, every=gs.heartbeat, timeout_s=60)
        assert gs.mode == HOLD  # heartbeats all along: the link holds
        gs.sends_heartbeats = False
        silent = gs.sim_time
        gs.wait(lambda: gs.mode == LAND, "the data-link loss failsafe to Land", timeout_s=60)
        assert gs.sim_time - silent <= 5.0 + 0.5  # COM_DL_LOSS_T after the last heartbeat
        assert "Connection to ground station lost, Land" in gs.statustexts
        gs.sends_heartbeats = True
        gs.wait(lambda: "Data link regained" in gs.statustexts, "the link regained", timeout_s=30)
        assert gs.mode == LAND  # the failsafe's mode stays until the user changes it


def test_flying_past_gf_max_hor_dist_returns_to_the_closer_rally_point_and_lands_there(tmp_path):
    with hovering(tmp_path, altitude=8.0) as gs:
        client = MissionClient(gs)
        rally = (REL, M.MAV_CMD_NAV_RALLY_POINT, 0, 0, 0, 0, *latlon_e7(20.0, 0.0), 0.0)
        assert client.upload(M.MAV_MISSION_TYPE_RALLY, [rally]) == M.MAV_MISSION_ACCEPTED
        set_param(gs, "GF_MAX_HOR_DIST", 25.0)
        set_param(gs, "GF_ACTION", 3)  # Return
        set_param(gs, "RTL_RETURN_ALT", 8.0)
        lat, lon = latlon_e7(50.0, 0.0)
        ack = gs.command(M.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, lat * 1e-7, lon * 1e-7, HOME.alt + 8.0)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: gs.mode == RETURN_MODE, "the geofence failsafe to Return", timeout_s=60)
        assert any("beyond GF_MAX_HOR_DIST 25 m" in text for text in gs.statustexts)
        farthest = [0.0]

        def far() -> None:
            farthest[0] = max(farthest[0], gs.latest["LOCAL_POSITION_NED"].x)

        gs.wait(lambda: not gs.armed, "Return to land and disarm", timeout_s=120, every=far)
        final = gs.latest["LOCAL_POSITION_NED"]
        print(f"breached at 25 m, farthest {farthest[0]:.1f} m north, landed at ({final.x:.2f}, {final.y:.2f}) m")
        assert farthest[0] < 40.0 and math.hypot(final.x - 20.0, final.y) <= 2.0


def test_gps_loss_in_a_hover_descends_and_ends_on_the_ground_disarmed(tmp_path):
    with hovering(tmp_path, altitude=10.0) as gs:
        set_param(gs, "SYS_FAILURE_EN", 1)
        assert gs.command(M.MAV_CMD_INJECT_FAILURE, 4, 1, 0).result == M.MAV_RESULT_ACCEPTED  # GPS OFF
        gs.wait(lambda: gs.mode == LAND, "Descend (reported as AUTO.LAND, as PX4 does)", timeout_s=30)
        gs.wait(lambda: gs.latest["GPS_RAW_INT"].fix_type == M.GPS_FIX_TYPE_NO_FIX, "GPS_RAW_INT without a fix")
        assert not gs.latest["SYS_STATUS"].onboard_control_sensors_health & M.MAV_SYS_STATUS_SENSOR_GPS
        assert gs.set_mode(HOLD).result == M.MAV_RESULT_TEMPORARILY_REJECTED  # Hold needs a position
        gs.wait(lambda: not gs.armed, "the landing and the disarm", timeout_s=90)
        assert gs.altitude < 0.5
        said = [text for text in gs.statustexts if text in (
            "GPS lost: no position estimate", "Position lost, Descend", "Failsafe activated: Descend",
            "Landing detected", "Disarmed after landing")]  # fmt: skip
        assert said == ["GPS lost: no position estimate", "Position lost, Descend", "Failsafe activated: Descend",
                        "Landing detected", "Disarmed after landing"]  # fmt: skip


def test_a_go_to_into_an_uploaded_exclusion_zone_stops_in_hold_at_its_edge(tmp_path):
    with hovering(tmp_path, altitude=5.0) as gs:
        client = MissionClient(gs)
        zone = (REL, M.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, 10.0, 0, 0, 0, *latlon_e7(30.0, 0.0), 0.0)
        assert client.upload(M.MAV_MISSION_TYPE_FENCE, [zone]) == M.MAV_MISSION_ACCEPTED  # GF_ACTION 2: Hold
        lat, lon = latlon_e7(60.0, 0.0)
        ack = gs.command(M.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, lat * 1e-7, lon * 1e-7, HOME.alt + 5.0)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: "Geofence violated: inside exclusion zone 1, Hold" in gs.statustexts, "the breach", 60)
        gs.wait(lambda: math.hypot(*gs.velocity[0:2]) < 0.3, "Hold to stop the vehicle", timeout_s=60)
        stopped = gs.latest["LOCAL_POSITION_NED"].x
        print(f"stopped {stopped:.1f} m north (the zone begins at 20 m)")
        assert 20.0 <= stopped < 30.0 and gs.mode == HOLD


def test_offboard_loss_with_manual_control_heard_takes_position_or_altitude_as_px4(tmp_path):
    """COM_OBL_RC_ACT 0 / 1 with MANUAL_CONTROL streaming: Position / Altitude (without it: Hold, the test above's
    commander-level twin in test_failsafes.py)."""
    with hovering(tmp_path) as gs:
        set_param(gs, "COM_RC_LOSS_T", 5.0)  # lockstep runs faster than the wall clock the sticks are sent on

        def sticks() -> None:
            gs.conn.mav.manual_control_send(1, 0, 0, 500, 0, 0)

        def both() -> None:
            gs.velocity_setpoint(0.0, 0.0, 0.0)
            sticks()

        for action, mode, name in ((0, 3 << 16, "Position"), (1, 2 << 16, "Altitude")):
            set_param(gs, "COM_OBL_RC_ACT", action)
            both()
            gs.pump(0.02)
            assert gs.set_mode(OFFBOARD).result == M.MAV_RESULT_ACCEPTED
            gs.wait(lambda: gs.mode == OFFBOARD, "Offboard", every=both)
            gs.wait(lambda: gs.mode == mode, f"the offboard loss failsafe to {name}", timeout_s=30, every=sticks)
            gs.wait(lambda: f"Failsafe activated: {name}" in gs.statustexts, "the failsafe's STATUSTEXT", every=sticks)
            assert gs.armed and gs.altitude > 15.0


def test_flight_termination_stops_the_motors_until_cleared_and_refuses_arming_meanwhile(tmp_path):
    # MAVSDK's action.terminate(): DO_FLIGHTTERMINATION param1 1, from a hover at 20 m flown by the MPC.
    with hovering(tmp_path) as gs:
        assert gs.command(M.MAV_CMD_DO_FLIGHTTERMINATION, math.nan).result == M.MAV_RESULT_DENIED
        texts = len(gs.statustexts)
        assert gs.command(M.MAV_CMD_DO_FLIGHTTERMINATION, 1).result == M.MAV_RESULT_ACCEPTED
        said(gs, "Flight termination: motors off", texts)
        gs.wait(lambda: not gs.armed and gs.latest["HEARTBEAT"].system_status == M.MAV_STATE_FLIGHT_TERMINATION,
                "the termination in the HEARTBEAT")  # fmt: skip
        gs.wait(lambda: gs.altitude < 0.5 and gs.latest["SERVO_OUTPUT_RAW"].servo1_raw <= 1000, "the fall", 30)
        refused = gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1, 21196)  # not even forced
        assert refused.result == M.MAV_RESULT_DENIED
        said(gs, "Arming denied: flight terminated", texts)
        # param1 0 clears it: the HEARTBEAT says STANDBY and arming is judged as usual again (where the fall left
        # the vehicle: on its gear it arms, tumbled it is not level).
        assert gs.command(M.MAV_CMD_DO_FLIGHTTERMINATION, 0).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: gs.latest["HEARTBEAT"].system_status == M.MAV_STATE_STANDBY, "the termination cleared")
        texts = len(gs.statustexts)
        attitude = gs.latest["ATTITUDE"]
        level = max(abs(attitude.roll), abs(attitude.pitch)) < math.radians(30.0)
        result = gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result
        print(f"after the fall: roll {math.degrees(attitude.roll):.1f}, pitch {math.degrees(attitude.pitch):.1f} deg; "
              f"arming {result}")  # fmt: skip
        assert result == (M.MAV_RESULT_ACCEPTED if level else M.MAV_RESULT_DENIED)
        assert not any("flight terminated" in text for text in gs.statustexts[texts:])
