"""Home as PX4's commander sets it and the rest of Return (issue 11 items 3, 4, 8; docs/mavlink.md, "Commands" (DO_SET_HOME),
docs/failsafes.md "Return and rally points"), through MAVLink, lockstep, the default controller (the MPC):
home moves to where the vehicle is disarmed on the ground and arms, not over a DO_SET_HOME home; a
GLOBAL_RELATIVE_ALT target is above home, not the local origin, and terrain altitudes are refused; Return's
altitude follows RTL_MIN_DIST and RTL_CONE_ANG, it descends to RTL_DESCEND_ALT and waits RTL_LAND_DELAY (-1: for
ever) before landing; bad values refused."""

from __future__ import annotations

import math

import pymap3d
import pytest

from autopilot.storage.parameters import BY_NAME, encode_value
from tests.sitl.ground_station import HOLD, OFFBOARD, MissionClient, said
from tests.sitl.test_mavlink_failsafes import hovering, set_param
from tests.sitl.test_mavlink_navigation import HOME as ORIGIN  # PX4 SITL's default: every vehicle's local origin here
from tests.sitl.test_mavlink_navigation import REL, RETURN_MODE, latlon_e7
from tests.sitl.test_mavlink_offboard_position import POSITION_MASK, here
from transport.mavlink import mavlink as M

TERRAIN = M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT


def command_int(gs, command: int, frame: int, x: int, y: int, z: float, *params: float):
    """COMMAND_INT to 1/1; the COMMAND_ACK for it."""
    p = list(params) + [0.0] * (4 - len(params))
    start = len(gs.acks)
    gs.conn.mav.command_int_send(gs.vehicle, 1, frame, command, 0, 0, *p, x, y, z)
    gs.wait(lambda: any(a.command == command for a in gs.acks[start:]), f"COMMAND_ACK for {command}")
    return next(a for a in gs.acks[start:] if a.command == command)


def home_after(gs, time_ms: int):
    """The first HOME_POSITION sent after simulation time `time_ms`."""
    gs.wait(lambda: "HOME_POSITION" in gs.latest and gs.latest["HOME_POSITION"].time_usec > time_ms * 1000,
            "a HOME_POSITION")  # fmt: skip
    return gs.latest["HOME_POSITION"]


def test_home_follows_the_vehicle_on_the_ground_and_arming_but_not_over_a_set_home(tmp_path):
    with hovering(tmp_path, 0.0) as gs:  # on the ground
        # The first valid position: home is where the vehicle stands (its centre of gravity over the origin).
        first = home_after(gs, 0)
        x, y, z = here(gs)
        assert math.hypot(first.x - x, first.y - y) < 0.05 and abs(first.z - z) < 0.05 and z < 0.0
        # Fly 15 m north and land there: disarmed on the ground, home follows (PX4: moved more than 1 m).
        assert gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == M.MAV_RESULT_ACCEPTED
        assert gs.command(M.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, math.nan).result == \
            M.MAV_RESULT_ACCEPTED  # fmt: skip
        gs.wait(lambda: gs.mode == HOLD and gs.altitude > 2.0, "the takeoff", 60)
        lat, lon = latlon_e7(15.0, 0.0)
        assert command_int(gs, M.MAV_CMD_DO_REPOSITION, REL, lat, lon, 3.0, -1, 1).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: math.hypot(here(gs)[0] - 15.0, here(gs)[1]) < 1.0, "the go-to", 60)
        assert gs.command(M.MAV_CMD_NAV_LAND).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: not gs.armed, "the landing and the disarm", 90)
        landed = here(gs)
        moved = home_after(gs, gs.time_boot_ms)
        assert math.hypot(moved.x - landed[0], moved.y - landed[1]) < 0.3 and abs(moved.z - landed[2]) < 0.3
        # Arming there sets home there (the same place: PX4 sets it at every arming).
        before = gs.time_boot_ms
        assert gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == M.MAV_RESULT_ACCEPTED
        armed_home = home_after(gs, before)
        assert math.hypot(armed_home.x - landed[0], armed_home.y - landed[1]) < 0.3
        assert gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == M.MAV_RESULT_ACCEPTED
        # A home given in coordinates (PX4's manual home) stays: not moved by arming.
        set_lat, set_lon, _ = pymap3d.ned2geodetic(-20.0, 5.0, 0.0, ORIGIN.lat, ORIGIN.lon, ORIGIN.alt)
        assert gs.command(M.MAV_CMD_DO_SET_HOME, 0, 0, 0, math.nan, set_lat, set_lon, ORIGIN.alt + 3.0).result == \
            M.MAV_RESULT_ACCEPTED  # fmt: skip
        gs.wait(lambda: abs(gs.latest["HOME_POSITION"].x + 20.0) < 0.3, "the new home")
        assert gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == M.MAV_RESULT_ACCEPTED
        gs.wait_sim(1.0)
        kept = gs.latest["HOME_POSITION"]
        assert abs(kept.x + 20.0) < 0.3 and abs(kept.y - 5.0) < 0.3 and abs(kept.z + 3.0) < 0.1


def test_relative_altitudes_are_above_home_and_terrain_altitudes_are_refused(tmp_path):
    with hovering(tmp_path, 12.0) as gs:
        # Home 10 m above the origin, over it: a relative altitude of 15 m is 25 m above the origin.
        assert gs.command(M.MAV_CMD_DO_SET_HOME, 0, 0, 0, math.nan, ORIGIN.lat, ORIGIN.lon, ORIGIN.alt + 10.0).result \
            == M.MAV_RESULT_ACCEPTED  # fmt: skip
        gs.wait(lambda: abs(gs.latest["HOME_POSITION"].z + 10.0) < 0.1, "the new home")
        texts = len(gs.statustexts)
        lat, lon = latlon_e7(10.0, 0.0)
        assert command_int(gs, M.MAV_CMD_DO_REPOSITION, TERRAIN, lat, lon, 15.0, -1, 1).result == M.MAV_RESULT_DENIED
        said(gs, "no terrain estimate", texts)
        assert command_int(gs, M.MAV_CMD_DO_REPOSITION, REL, lat, lon, 15.0, -1, 1).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: math.hypot(here(gs)[0] - 10.0, here(gs)[1]) < 1.0 and abs(gs.altitude - 25.0) < 1.0,
                "the go-to at 15 m above home", 60)  # fmt: skip
        # SET_POSITION_TARGET_GLOBAL_INT in GLOBAL_RELATIVE_ALT_INT: back over the origin, 5 m above home.
        lat, lon = latlon_e7(0.0, 0.0)

        def stream(frame: int = REL) -> None:
            gs.conn.mav.set_position_target_global_int_send(gs.time_boot_ms, gs.vehicle, 1, frame, POSITION_MASK, lat, lon,
                                                            5.0, 0, 0, 0, 0, 0, 0, 0, 0)  # fmt: skip

        texts = len(gs.statustexts)
        stream(TERRAIN)
        said(gs, "Set-point dropped: frame 11 (altitude above terrain) not supported", texts)
        stream()
        assert gs.set_mode(OFFBOARD).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: math.hypot(*here(gs)[0:2]) < 1.0 and abs(gs.altitude - 15.0) < 1.0,
                "the Offboard target 5 m above home", 60, every=stream)  # fmt: skip
        assert gs.latest["GLOBAL_POSITION_INT"].relative_alt == pytest.approx(5000, abs=1000)  # above home too


def test_return_altitude_descend_altitude_and_land_delay(tmp_path):
    with hovering(tmp_path, 8.0) as gs:
        for name, value in (("RTL_RETURN_ALT", 20.0), ("RTL_CONE_ANG", 60), ("NAV_ACC_RAD", 2.0),
                            ("RTL_DESCEND_ALT", 5.0), ("RTL_LAND_DELAY", -1.0)):  # fmt: skip
            set_param(gs, name, value)
        # Bad values refused, the old ones kept.
        texts = len(gs.statustexts)
        assert gs.param_set("RTL_LAND_DELAY", -2.0, M.MAV_PARAM_TYPE_REAL32).param_value == -1.0
        assert gs.param_set("RTL_MIN_DIST", 0.1, M.MAV_PARAM_TYPE_REAL32).param_value == 10.0
        assert gs.param_set("RTL_DESCEND_ALT", math.nan, M.MAV_PARAM_TYPE_REAL32).param_value == 5.0
        as_int32 = encode_value(BY_NAME["RTL_CONE_ANG"], 7)  # an INT32's encoding, for a REAL32 parameter
        assert gs.param_set("RTL_DESCEND_ALT", as_int32, M.MAV_PARAM_TYPE_INT32).param_value == 5.0
        for why in ("RTL_LAND_DELAY: -2 outside -1..3600", "RTL_MIN_DIST: 0.1 outside", "not a finite number",
                    "Param set RTL_DESCEND_ALT: type 6"):  # fmt: skip
            said(gs, why, texts)
        # 25 m north at 8 m: beyond RTL_MIN_DIST (10 m) the return altitude is RTL_RETURN_ALT; within it (50 m)
        # the 60 deg cone's height there, 25 / tan 60 = 14.4 m.
        lat, lon = latlon_e7(25.0, 0.0)
        assert command_int(gs, M.MAV_CMD_DO_REPOSITION, REL, lat, lon, 8.0, -1, 1).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: math.hypot(here(gs)[0] - 25.0, here(gs)[1]) < 0.3 and math.hypot(*gs.velocity) < 0.3,
                "the go-to, settled", 60)  # fmt: skip
        texts = len(gs.statustexts)
        assert gs.command(M.MAV_CMD_NAV_RETURN_TO_LAUNCH).result == M.MAV_RESULT_ACCEPTED
        assert said(gs, "RTL: start return", texts) == f"RTL: start return at {math.ceil(ORIGIN.alt + 20)} m (20 m " \
            "above destination)"  # fmt: skip
        assert gs.set_mode(HOLD).result == M.MAV_RESULT_ACCEPTED
        set_param(gs, "RTL_MIN_DIST", 50.0)
        texts = len(gs.statustexts)
        distance = math.hypot(*here(gs)[0:2])  # Return climbed before it turned home: still about 25 m out
        assert gs.command(M.MAV_CMD_NAV_RETURN_TO_LAUNCH).result == M.MAV_RESULT_ACCEPTED
        height = int(said(gs, "RTL: start return", texts).split("(")[1].split(" m above")[0])
        assert height == math.ceil(distance / math.tan(math.radians(60))) == 15
        # RTL_LAND_DELAY -1: over home it descends to RTL_DESCEND_ALT and stays there, in Return, not landing.
        highest = [0.0]
        gs.wait(lambda: highest.__setitem__(0, max(highest[0], gs.altitude)) or any(
            "RTL: completed, loitering" in t for t in gs.statustexts[texts:]), "the loiter", 120)  # fmt: skip
        gs.wait(lambda: abs(gs.altitude - 5.0) < 0.5, "the descent to RTL_DESCEND_ALT", 60)
        assert 13.9 < highest[0] < 15.5  # the cone's height
        gs.wait_sim(5.0)
        assert gs.mode == RETURN_MODE and abs(gs.altitude - 5.0) < 0.5 and math.hypot(*here(gs)[0:2]) < 1.0
        assert gs.landed_state == M.MAV_LANDED_STATE_IN_AIR
        # RTL_LAND_DELAY 3 s: Return again from here waits 3 s at RTL_DESCEND_ALT, then lands and disarms.
        set_param(gs, "RTL_LAND_DELAY", 3.0)
        assert gs.set_mode(HOLD).result == M.MAV_RESULT_ACCEPTED
        texts, beats = len(gs.statustexts), len(gs.heartbeats)
        assert gs.command(M.MAV_CMD_NAV_RETURN_TO_LAUNCH).result == M.MAV_RESULT_ACCEPTED
        samples: list[tuple[float, float]] = []  # (simulation time, altitude)
        gs.wait(lambda: samples.append((gs.sim_time, gs.altitude)) or gs.altitude < 4.0, "the landing", 60)
        started = next(t for t, beat in gs.heartbeats[beats:] if beat.custom_mode == RETURN_MODE)
        descending = next(t for t, altitude in samples if altitude < 4.0)
        held = [altitude for t, altitude in samples if t <= started + 3.0]
        print(f"Return: {descending - started:.2f} s from Return to 1 m below RTL_DESCEND_ALT, held "
              f"{min(held):.2f}..{max(held):.2f} m")  # fmt: skip
        # 3 s held, then at most MPC_LAND_SPEED (0.7 m/s) down: at least 1.4 s more to 1 m below.
        assert 4.4 <= descending - started <= 9.0 and all(abs(altitude - 5.0) < 0.5 for altitude in held)
        said(gs, "RTL: land at destination", texts)
        gs.wait(lambda: not gs.armed, "the landing and the disarm", 120)
        assert math.hypot(*here(gs)[0:2]) < 1.0


def mission_landing_rows(waypoint: tuple[float, float], landing: tuple[float, float]) -> list[tuple]:
    """A waypoint at 10 m, then the landing: DO_LAND_START and a NAV_LAND."""
    far, over = latlon_e7(*waypoint), latlon_e7(*landing)
    return [(REL, M.MAV_CMD_NAV_WAYPOINT, 0, 0, 0, math.nan, *far, 10.0),
            (M.MAV_FRAME_MISSION, M.MAV_CMD_DO_LAND_START, 0, 0, 0, 0, 0, 0, 0.0),
            (REL, M.MAV_CMD_NAV_LAND, 0, 0, 0, math.nan, *over, 0.0)]  # fmt: skip


def test_rtl_type_1_returns_to_the_mission_landing_and_flies_it_from_do_land_start(tmp_path):
    # A mission (not flown) whose landing is 30 m north, 20 m east. With RTL_TYPE 1 and no rally point, Return
    # climbs to RTL_RETURN_ALT and flies the mission from DO_LAND_START: over the land item at that altitude, down.

    with hovering(tmp_path, 8.0) as gs:
        texts = len(gs.statustexts)
        rtl_type = BY_NAME["RTL_TYPE"]
        refused = gs.param_set("RTL_TYPE", encode_value(rtl_type, 2), M.MAV_PARAM_TYPE_INT32)  # PX4's mission path
        assert refused.param_value == encode_value(rtl_type, 0)
        said(gs, "RTL_TYPE: 2 outside 0..1", texts)
        for name, value in (("RTL_TYPE", 1), ("RTL_RETURN_ALT", 12.0)):
            set_param(gs, name, value)
        rows = mission_landing_rows((60.0, 0.0), (30.0, 20.0))
        assert MissionClient(gs).upload(M.MAV_MISSION_TYPE_MISSION, rows) == M.MAV_MISSION_ACCEPTED
        texts = len(gs.statustexts)
        assert gs.command(M.MAV_CMD_NAV_RETURN_TO_LAUNCH).result == M.MAV_RESULT_ACCEPTED
        assert said(gs, "RTL: start return", texts).endswith("(12 m above mission landing)")
        highest, lowest_away, reached, modes = [0.0], [99.0], set(), set()

        def sample() -> bool:
            north, east, _ = here(gs)
            highest[0] = max(highest[0], gs.altitude)
            if highest[0] > 11.0 and math.hypot(north - 30.0, east - 20.0) > 3.0:  # climbed, not yet over it
                lowest_away[0] = min(lowest_away[0], gs.altitude)
            if gs.armed:
                modes.add(gs.mode)
            if "MISSION_ITEM_REACHED" in gs.latest:
                reached.add(gs.latest["MISSION_ITEM_REACHED"].seq)
            return not gs.armed

        gs.wait(sample, "the mission landing and the disarm", 180)
        north, east, _ = here(gs)
        print(f"landed at ({north:.2f}, {east:.2f}), highest {highest[0]:.1f} m, lowest before the landing point "
              f"{lowest_away[0]:.1f} m, items reached {sorted(reached)}")  # fmt: skip
        assert math.hypot(north - 30.0, east - 20.0) < 2.0  # the mission's land item, not home
        assert 11.0 < highest[0] < 13.5 and lowest_away[0] > 10.5  # the approach at the return altitude
        assert modes == {RETURN_MODE} and 2 in reached and 0 not in reached


def test_return_while_mission_flies_its_landing_goes_on_with_it(tmp_path):
    # PX4's navigator does not switch when Return comes during the mission's landing: no climb, the same landing.
    from tests.sitl.test_mavlink_navigation import MISSION_MODE

    with hovering(tmp_path, 8.0) as gs:
        for name, value in (("RTL_TYPE", 1), ("RTL_RETURN_ALT", 30.0)):
            set_param(gs, name, value)
        rows = mission_landing_rows((0.0, 5.0), (12.0, 5.0))
        assert MissionClient(gs).upload(M.MAV_MISSION_TYPE_MISSION, rows) == M.MAV_MISSION_ACCEPTED
        assert gs.set_mode(MISSION_MODE).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: gs.latest["MISSION_CURRENT"].seq == 2 and gs.altitude < 7.0, "the mission's descent", 120)
        texts = len(gs.statustexts)
        assert gs.command(M.MAV_CMD_NAV_RETURN_TO_LAUNCH).result == M.MAV_RESULT_ACCEPTED
        said(gs, "RTL: continuing the mission landing", texts)
        highest = [0.0]
        gs.wait(lambda: highest.__setitem__(0, max(highest[0], gs.altitude)) or not gs.armed, "the landing", 120)
        north, east, _ = here(gs)
        print(f"landed at ({north:.2f}, {east:.2f}); highest after Return {highest[0]:.1f} m")
        assert highest[0] < 7.5 and math.hypot(north - 12.0, east - 5.0) < 2.0
