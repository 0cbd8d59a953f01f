"""Yaw set-points end to end (docs/mavlink.md, "Yaw"): Offboard yaw and yaw rate, a mission
waypoint's param4, DO_REPOSITION's param4, DO_ORBIT's yaw behaviour, the yaw stick, through MAVLink in lockstep,
flown by the default controller (the MPC) and once by the PID; the shaping and the rule of where a yaw is honoured as
pure functions."""

from __future__ import annotations

import math

import pytest

from aircraft.frames import wrap
from tests.sitl.ground_station import HOLD, OFFBOARD, MissionClient, said
from tests.sitl.test_mavlink_failsafes import hovering, set_param
from tests.sitl.test_mavlink_manual_control import POSCTL
from tests.sitl.test_mavlink_missions import rows_of
from tests.sitl.test_mavlink_navigation import MISSION_MODE, ORBIT_MODE, latlon_e7
from transport.mavlink import mavlink as M

ALTITUDE = 20.0
VELOCITY_YAW = 0b100111000111  # velocity and yaw used (MAVSDK's VelocityNedYaw), yaw rate ignored
VELOCITY_YAW_RATE = 0b010111000111  # velocity and yaw rate used (MAVSDK's VelocityBodyYawspeed), yaw ignored


# ---- through MAVLink -------------------------------------------------------------------------------------------------
def yaw_deg(gs) -> float:
    return math.degrees(gs.latest["ATTITUDE"].yaw)


@pytest.fixture
def mpc_gs(tmp_path):
    """A ground station on a vehicle hovering at 20 m in Hold, flown by the MPC, in lockstep."""
    with hovering(tmp_path, ALTITUDE) as gs:
        yield gs


def offboard(gs, send) -> None:
    send()
    gs.pump(0.05)
    assert gs.set_mode(OFFBOARD).result == M.MAV_RESULT_ACCEPTED


def measured_rate(gs, send, seconds: float) -> float:
    """The mean yaw rate (rad/s) over `seconds` of simulated time, the yaw unwrapped sample by sample."""
    turned, last, start = 0.0, gs.latest["ATTITUDE"].yaw, gs.sim_time

    def sample() -> None:
        nonlocal turned, last
        send()
        yaw = gs.latest["ATTITUDE"].yaw
        turned += wrap(yaw - last)
        last = yaw

    gs.wait_sim(seconds, every=sample)
    return turned / (gs.sim_time - start)


@pytest.mark.parametrize("controller", ["mpc", "pid"])
def test_offboard_yaw_turns_the_hover_to_it_and_a_yaw_rate_turns_at_that_rate(tmp_path, controller):
    with hovering(tmp_path, ALTITUDE, controller) as gs:
        mav = gs.conn.mav

        def heading(yaw: float):
            return lambda: mav.set_position_target_local_ned_send(
                gs.time_boot_ms, gs.vehicle, 1, M.MAV_FRAME_LOCAL_NED, VELOCITY_YAW, 0, 0, 0, 0, 0, 0, 0, 0, 0, yaw, 0
            )

        offboard(gs, heading(math.radians(90.0)))
        gs.wait_sim(6.0, every=heading(math.radians(90.0)))  # 90 deg at MPC_YAWRAUTO_MAX (30 deg/s) and settling
        east = yaw_deg(gs)
        gs.wait_sim(7.0, every=heading(math.radians(-135.0)))  # 135 deg the short way, through 180 deg
        south_west = yaw_deg(gs)

        def spin():
            mav.set_position_target_local_ned_send(gs.time_boot_ms, gs.vehicle, 1, M.MAV_FRAME_BODY_NED, VELOCITY_YAW_RATE,
                                                   0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0.5)  # fmt: skip

        gs.wait_sim(1.0, every=spin)  # spinning up
        rate = measured_rate(gs, spin, 4.0)
        position = gs.latest["LOCAL_POSITION_NED"]
        print(f"{controller}: heading {east:.2f} deg for 90, {south_west:.2f} deg for -135; yaw rate {rate:.3f} rad/s "
              f"for 0.5; drift {math.hypot(position.x, position.y):.2f} m, altitude {-position.z:.2f} m")  # fmt: skip
        assert abs(east - 90.0) < 3.0 and abs(wrap(math.radians(south_west + 135.0))) < math.radians(3.0)
        assert abs(rate - 0.5) < 0.05
        assert abs(-position.z - ALTITUDE) < 1.0


def test_a_yaw_in_forward_flight_is_not_honoured_and_bad_yaws_are_refused(mpc_gs):
    gs = mpc_gs
    mav = gs.conn.mav

    def fast_north():  # 14 m/s north, asking the nose to point east
        mav.set_position_target_local_ned_send(gs.time_boot_ms, gs.vehicle, 1, M.MAV_FRAME_LOCAL_NED, VELOCITY_YAW, 0, 0,
                                               0, 14.0, 0, 0, 0, 0, 0, math.radians(90.0), 0)  # fmt: skip

    texts = len(gs.statustexts)
    for yaw, rate in ((math.inf, 0.0), (0.0, -math.inf), (math.nan, 10.0)):  # dropped, dropped, clamped to pi rad/s
        mav.set_position_target_local_ned_send(gs.time_boot_ms, gs.vehicle, 1, M.MAV_FRAME_LOCAL_NED, 0b000111000111, 0, 0, 0,
                                               0, 0, 0, 0, 0, 0, yaw, rate)  # fmt: skip
    for why in ("yaw or yaw rate infinite", "|yaw rate| <= 180 deg/s"):
        gs.wait(lambda: any(why in text for text in gs.statustexts[texts:]), f"the answer: {why}")
    offboard(gs, fast_north)
    gs.wait_sim(10.0, every=fast_north)
    print(f"at {math.hypot(*gs.velocity[0:2]):.1f} m/s: heading {yaw_deg(gs):.2f} deg")
    assert math.hypot(*gs.velocity[0:2]) > 12.0 and abs(yaw_deg(gs)) < 5.0


def test_a_hover_waypoint_with_a_yaw_arrives_with_that_heading_and_holds_it(mpc_gs):
    north, east = latlon_e7(15.0, 5.0)
    rows = [(M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_CMD_NAV_WAYPOINT, 0, 2.0, 0, -120.0, north, east, ALTITUDE)]
    gs = mpc_gs
    assert MissionClient(gs).upload(M.MAV_MISSION_TYPE_MISSION, rows) == M.MAV_MISSION_ACCEPTED
    assert gs.set_mode(MISSION_MODE).result == M.MAV_RESULT_ACCEPTED
    gs.wait(lambda: "MISSION_ITEM_REACHED" in gs.latest, "the waypoint reached", 120)
    reached = yaw_deg(gs)
    gs.wait_sim(3.0)
    position = gs.latest["LOCAL_POSITION_NED"]
    print(f"reached with heading {reached:.2f} deg, {yaw_deg(gs):.2f} deg 3 s later, at ({position.x:.2f}, "
          f"{position.y:.2f})")  # fmt: skip
    assert abs(reached + 120.0) <= 12.0  # MIS_YAW_ERR
    assert abs(yaw_deg(gs) + 120.0) < 3.0 and math.hypot(position.x - 15.0, position.y - 5.0) < 2.0


def test_with_a_yaw_timeout_a_waypoint_is_reached_on_its_position_and_then_turns_to_its_yaw(mpc_gs):
    gs = mpc_gs
    set_param(gs, "MIS_YAW_TMT", 5.0)
    north, east = latlon_e7(0.0, 3.0)
    rows = [(M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_CMD_NAV_WAYPOINT, 0, 2.0, 0, 180.0, north, east, ALTITUDE)]
    assert MissionClient(gs).upload(M.MAV_MISSION_TYPE_MISSION, rows) == M.MAV_MISSION_ACCEPTED
    start = gs.sim_time
    assert gs.set_mode(MISSION_MODE).result == M.MAV_RESULT_ACCEPTED
    gs.wait(lambda: "MISSION_ITEM_REACHED" in gs.latest, "the waypoint reached", 120)
    reached, after_s = yaw_deg(gs), gs.sim_time - start
    gs.wait_sim(8.0)
    print(f"MIS_YAW_TMT 5: reached after {after_s:.2f} s with heading {reached:.1f} deg; {yaw_deg(gs):.2f} deg 8 s "
          f"later")  # fmt: skip
    # 180 deg at MPC_YAWRAUTO_MAX (30 deg/s) takes 6 s: reached well before, on its position alone.
    assert abs(wrap(math.radians(reached - 180.0))) > math.radians(90.0)
    assert abs(wrap(math.radians(yaw_deg(gs) - 180.0))) < math.radians(3.0)


def test_an_orbit_faces_its_centre_by_default_goto_and_condition_yaw_turn_to_theirs(mpc_gs):
    gs = mpc_gs
    here = gs.latest["LOCAL_POSITION_NED"]
    centre = (here.x + 15.0, here.y)
    lat, lon = latlon_e7(*centre)
    # DO_ORBIT radius 15 m, 3 m/s, yaw behaviour NaN (PX4's default: front to the centre), centre 15 m north.
    ack = gs.command(M.MAV_CMD_DO_ORBIT, 15.0, 3.0, math.nan, math.nan, lat * 1e-7, lon * 1e-7, math.nan)
    assert ack.result == M.MAV_RESULT_ACCEPTED
    gs.wait(lambda: gs.mode == ORBIT_MODE, "Orbit")  # the HEARTBEAT showing it can come after the ACK
    gs.wait_sim(25.0)  # on the circle, a quarter turn and more
    errors = []

    def sample() -> None:
        p = gs.latest["LOCAL_POSITION_NED"]
        errors.append(wrap(math.atan2(centre[1] - p.y, centre[0] - p.x) - gs.latest["ATTITUDE"].yaw))

    gs.wait_sim(5.0, every=sample)
    worst = math.degrees(max(abs(e) for e in errors))
    print(f"orbit: nose off the centre by at most {worst:.2f} deg over 5 s")
    assert worst < 5.0
    texts = len(gs.statustexts)
    bad = gs.command(M.MAV_CMD_DO_ORBIT, 15.0, 3.0, 7.0, math.nan, math.nan, math.nan, math.nan)
    assert bad.result == M.MAV_RESULT_DENIED
    said(gs, "yaw behaviour", since=texts)  # the reason, among the texts since the command (another may come first)
    assert gs.command(M.MAV_CMD_CONDITION_YAW, 0, 0, 0, 0).result == M.MAV_RESULT_TEMPORARILY_REJECTED  # Hold only

    # Go-to here with a yaw (param4, rad as PX4 and MAVSDK send it): Hold, turned to it.
    ack = gs.command(M.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.radians(30.0), math.nan, math.nan, math.nan)
    assert ack.result == M.MAV_RESULT_ACCEPTED
    gs.wait(lambda: gs.mode == HOLD, "Hold after the go-to")  # from Orbit (the HEARTBEAT can come after the ACK)
    gs.wait_sim(6.0)
    print(f"go-to: heading {yaw_deg(gs):.2f} deg for 30")
    assert abs(yaw_deg(gs) - 30.0) < 3.0

    # MAV_CMD_CONDITION_YAW in Hold: 60 deg clockwise from here (param4 1, relative).
    assert gs.command(M.MAV_CMD_CONDITION_YAW, 60.0, 0, 1, 1).result == M.MAV_RESULT_ACCEPTED
    gs.wait_sim(5.0)
    print(f"condition yaw +60: heading {yaw_deg(gs):.2f} deg for 90")
    assert abs(yaw_deg(gs) - 90.0) < 3.0
    assert gs.command(M.MAV_CMD_CONDITION_YAW, 10.0, 0, 0, 2).result == M.MAV_RESULT_DENIED


def test_orbit_yaw_behaviours_hold_the_first_heading_follow_the_track_or_the_yaw_stick(mpc_gs):
    gs = mpc_gs
    assert gs.command(M.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.radians(40.0), math.nan, math.nan,
                      math.nan).result == M.MAV_RESULT_ACCEPTED  # fmt: skip
    gs.wait_sim(5.0)  # in Hold, turned to 40 deg
    here = gs.latest["LOCAL_POSITION_NED"]
    centre = (here.x + 15.0, here.y)
    lat, lon = latlon_e7(*centre)

    def orbit(behaviour: int) -> None:
        ack = gs.command(M.MAV_CMD_DO_ORBIT, 15.0, 3.0, behaviour, math.nan, lat * 1e-7, lon * 1e-7, math.nan)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: gs.mode == ORBIT_MODE, "Orbit")  # the HEARTBEAT showing it can come after the ACK

    def worst_error(seconds: float, wanted) -> tuple[float, float]:
        """The largest |yaw - wanted(position)| (deg) and the largest |distance to the centre - 15 m| over
        `seconds`."""
        yaw_errors, radial = [], []

        def sample() -> None:
            p = gs.latest["LOCAL_POSITION_NED"]
            yaw_errors.append(abs(wrap(wanted(p) - gs.latest["ATTITUDE"].yaw)))
            radial.append(abs(math.hypot(p.x - centre[0], p.y - centre[1]) - 15.0))

        gs.wait_sim(seconds, every=sample)
        return math.degrees(max(yaw_errors)), max(radial)

    # HOLD_INITIAL_HEADING: the nose stays where it was when the orbit began, whatever the position on the circle.
    orbit(M.ORBIT_YAW_BEHAVIOUR_HOLD_INITIAL_HEADING)
    gs.wait_sim(20.0)
    initial, radial = worst_error(5.0, lambda p: math.radians(40.0))
    # HOLD_FRONT_TANGENT_TO_CIRCLE: along the track; a positive radius orbits clockwise, so the track is the
    # direction to the centre turned 90 deg anticlockwise.
    orbit(M.ORBIT_YAW_BEHAVIOUR_HOLD_FRONT_TANGENT_TO_CIRCLE)
    gs.wait_sim(10.0)
    tangent, _ = worst_error(5.0, lambda p: math.atan2(centre[1] - p.y, centre[0] - p.x) - math.pi / 2)
    print(f"orbit: initial heading held within {initial:.2f} deg (on the circle within {radial:.2f} m), "
          f"tangent within {tangent:.2f} deg")  # fmt: skip
    assert initial < 3.0 and radial < 2.0 and tangent < 5.0

    # RC_CONTROLLED: the yaw stick turns the nose at its rate (0.3: 33.3 deg/s, as in Position mode), and centred
    # it holds the heading while the orbit goes on.
    stick_r = [300]

    def send() -> None:
        gs.conn.mav.manual_control_send(1, 0, 0, 500, stick_r[0], 0)

    set_param(gs, "COM_RC_LOSS_T", 5.0)  # lockstep runs faster than the wall clock the sticks are sent on
    send()
    orbit(M.ORBIT_YAW_BEHAVIOUR_RC_CONTROLLED)
    gs.wait_sim(1.0, every=send)
    rate = measured_rate(gs, send, 3.0)
    stick_r[0] = 0
    gs.wait_sim(2.0, every=send)
    held = gs.latest["ATTITUDE"].yaw
    gs.wait_sim(3.0, every=send)
    drift = math.degrees(abs(wrap(gs.latest["ATTITUDE"].yaw - held)))
    print(f"orbit, yaw stick 0.3: {math.degrees(rate):.1f} deg/s for 33.3; centred: {drift:.2f} deg in 3 s")
    assert abs(math.degrees(rate) - 100.0 / 3.0) < 3.0 and drift < 0.5 and gs.mode == ORBIT_MODE


def test_the_yaw_stick_turns_the_hover_at_its_rate_and_centred_stops_and_holds_the_heading(mpc_gs):
    gs = mpc_gs
    stick_r = [300]  # 0.3: (0.3 - MPC_HOLD_DZ) / (1 - MPC_HOLD_DZ) of MPC_MAN_Y_MAX (150 deg/s) = 33.3 deg/s

    def send() -> None:
        gs.conn.mav.manual_control_send(1, 0, 0, 500, stick_r[0], 0)

    set_param(gs, "COM_RC_LOSS_T", 5.0)  # lockstep runs faster than the wall clock the sticks are sent on
    send()
    gs.pump(0.1)
    assert gs.set_mode(POSCTL).result == M.MAV_RESULT_ACCEPTED
    gs.wait_sim(1.0, every=send)
    rate = measured_rate(gs, send, 3.0)
    stick_r[0] = 0
    released = yaw_deg(gs)
    gs.wait_sim(3.0, every=send)
    held = yaw_deg(gs)
    gs.wait_sim(2.0, every=send)
    print(f"yaw stick 0.3: {math.degrees(rate):.1f} deg/s for 33.3; released at {released:.1f} deg, "
          f"{held:.1f} deg 3 s later, {yaw_deg(gs):.1f} deg 2 s after that")  # fmt: skip
    assert abs(math.degrees(rate) - 100.0 / 3.0) < 3.0
    assert 0.0 < wrap(math.radians(held - released)) < math.radians(15.0)  # stopped, not turned back, and locked
    assert abs(wrap(math.radians(yaw_deg(gs) - held))) < math.radians(0.5)


def as_text(rows: list[tuple]) -> list[tuple[str, ...]]:
    """Mission rows comparable with NaN in them."""
    return [tuple(str(float(value)) for value in row) for row in rows]


def fly_mission(gs) -> None:
    """Mission mode, until the stored mission is complete."""
    assert gs.set_mode(MISSION_MODE).result == M.MAV_RESULT_ACCEPTED
    gs.wait(lambda: gs.latest["MISSION_CURRENT"].mission_state == M.MISSION_STATE_ACTIVE, "the mission's start", 30)
    gs.wait(lambda: gs.latest["MISSION_CURRENT"].mission_state == M.MISSION_STATE_COMPLETE, "the mission's end", 120)


def test_a_region_of_interest_turns_the_nose_on_a_missions_legs_and_payload_items_are_passed(mpc_gs):
    # A mission as QGroundControl plans one with a camera: the region of interest 40 m east of home, the camera and
    # gimbal items (no payload on this airframe: stored, sent back as they came, passed), a waypoint 20 m north, a
    # NAV_LOITER_TO_ALT 8 m above it.
    gs = mpc_gs
    roi_lat, roi_lon = latlon_e7(0.0, 40.0)
    north, east = latlon_e7(20.0, 0.0)
    mission = M.MAV_FRAME_MISSION
    rows = [
        (M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_CMD_DO_SET_ROI_LOCATION, 0, 0, 0, 0, roi_lat, roi_lon, 0.0),
        (mission, M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, -90.0, 0.0, math.nan, math.nan, 0, 0, 0.0),
        (mission, M.MAV_CMD_IMAGE_START_CAPTURE, 0, 2.0, 0, math.nan, 0, 0, 0.0),
        (M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_CMD_NAV_WAYPOINT, 0, 2.0, 0, math.nan, north, east, ALTITUDE),
        (mission, M.MAV_CMD_DO_SET_CAM_TRIGG_DIST, 0, 0, 1, 0, 0, 0, 0.0),
        (mission, M.MAV_CMD_IMAGE_STOP_CAPTURE, 0, math.nan, math.nan, math.nan, 0, 0, 0.0),
        (M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_CMD_NAV_LOITER_TO_ALT, 0, 25.0, 0, 0, north, east, ALTITUDE + 8),
    ]  # fmt: skip
    client = MissionClient(gs)
    assert client.upload(M.MAV_MISSION_TYPE_MISSION, rows) == M.MAV_MISSION_ACCEPTED
    assert as_text(rows_of(client.download(M.MAV_MISSION_TYPE_MISSION))) == as_text(rows)
    fly_mission(gs)
    gs.wait_sim(4.0)  # holding at the waypoint, still pointing at the region of interest

    def roi_error_deg() -> float:
        p = gs.latest["LOCAL_POSITION_NED"]
        return math.degrees(wrap(math.atan2(40.0 - p.y, 0.0 - p.x) - gs.latest["ATTITUDE"].yaw))

    p = gs.latest["LOCAL_POSITION_NED"]
    print(f"held at ({p.x:.2f}, {p.y:.2f}), heading {yaw_deg(gs):.2f} deg, {roi_error_deg():.2f} deg off the ROI")
    assert math.hypot(p.x - 20.0, p.y) < 2.0 and abs(roi_error_deg()) < 3.0
    assert -p.z > ALTITUDE + 5.0  # NAV_LOITER_TO_ALT climbed over the waypoint (reached within 3 m of its altitude)

    # DO_SET_ROI_NONE: the items' own yaw again (a waypoint's param4), in the next mission too.
    north, east = latlon_e7(20.0, 8.0)
    rows = [
        (mission, M.MAV_CMD_DO_SET_ROI_NONE, 0, 0, 0, 0, 0, 0, 0.0),
        (M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_CMD_NAV_WAYPOINT, 0, 2.0, 0, -60.0, north, east, ALTITUDE),
    ]
    assert client.upload(M.MAV_MISSION_TYPE_MISSION, rows) == M.MAV_MISSION_ACCEPTED
    assert gs.set_mode(HOLD).result == M.MAV_RESULT_ACCEPTED
    fly_mission(gs)
    gs.wait_sim(4.0)
    print(f"after DO_SET_ROI_NONE: heading {yaw_deg(gs):.2f} deg")
    assert abs(yaw_deg(gs) + 60.0) < 3.0

    # The command (QGroundControl's "ROI" action), while the mission holds at its end in Mission: the nose turns to
    # its point, 30 m south of home, at once. Bad ones are DENIED. A new mission resets it (PX4): its waypoint's yaw.
    assert gs.command(M.MAV_CMD_DO_SET_ROI, 7).result == M.MAV_RESULT_DENIED
    assert gs.command(M.MAV_CMD_DO_SET_ROI_LOCATION, 0, 0, 0, 0, 91.0, 8.5, 0).result == M.MAV_RESULT_DENIED
    south_lat, south_lon = latlon_e7(-30.0, 0.0)
    ack = gs.command(M.MAV_CMD_DO_SET_ROI_LOCATION, 0, 0, 0, 0, south_lat * 1e-7, south_lon * 1e-7, 0.0)
    assert ack.result == M.MAV_RESULT_ACCEPTED
    gs.wait_sim(6.0)  # 110 deg at MPC_YAWRAUTO_MAX (30 deg/s)
    p = gs.latest["LOCAL_POSITION_NED"]
    south_error = math.degrees(wrap(math.atan2(0.0 - p.y, -30.0 - p.x) - gs.latest["ATTITUDE"].yaw))
    print(f"DO_SET_ROI_LOCATION (command) at the mission's end: heading {yaw_deg(gs):.2f} deg, {south_error:.2f} deg "
          f"off the ROI")  # fmt: skip
    assert abs(south_error) < 3.0
    rows = [(M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_CMD_NAV_WAYPOINT, 0, 2.0, 0, 30.0, north, east, ALTITUDE)]
    assert client.upload(M.MAV_MISSION_TYPE_MISSION, rows) == M.MAV_MISSION_ACCEPTED
    assert gs.set_mode(HOLD).result == M.MAV_RESULT_ACCEPTED
    fly_mission(gs)
    gs.wait_sim(4.0)
    print(f"a new mission: heading {yaw_deg(gs):.2f} deg")
    assert abs(yaw_deg(gs) - 30.0) < 3.0
