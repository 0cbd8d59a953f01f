"""Navigation through MAVLink (issue 11 items 2 and 3, docs/missions.md, "Return", "Go-to", "Orbit"):
a mission flown by the unified MPC with no DO_VTOL_TRANSITION (it transitions when the legs ask for cruise speed),
Go-to (DO_REPOSITION) then Return, Orbit; the refusals with their reasons. Lockstep, the default controller."""

from __future__ import annotations

import math

import pymap3d
import pytest

from tests.sitl.ground_station import HOLD, MissionClient, said
from tests.sitl.mavlink_sitl import start_sitl
from transport.geodesy import Home
from transport.mavlink import mavlink as M

HOME = Home()
REL = M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
MISSION_MODE = (4 << 16) | (4 << 24)
RETURN_MODE = (4 << 16) | (5 << 24)
ORBIT_MODE = (3 << 16) | (1 << 24)


def latlon_e7(north: float, east: float) -> tuple[int, int]:
    lat, lon, _ = pymap3d.ned2geodetic(north, east, 0.0, HOME.lat, HOME.lon, HOME.alt)
    return int(round(lat * 1e7)), int(round(lon * 1e7))


def waypoint(north: float, east: float, alt: float, command: int = M.MAV_CMD_NAV_WAYPOINT) -> tuple:
    return (REL, command, 0, 0, 0, math.nan, *latlon_e7(north, east), alt)


# ---- through the real processes ---------------------------------------------------------------------------------------
def fly(sitl, until, timeout_s: float, sample) -> None:
    gs = sitl.gs

    def done() -> bool:
        if "LOCAL_POSITION_NED" in gs.latest:
            sample(gs.latest["LOCAL_POSITION_NED"])
        return until()

    gs.wait(done, "the flight to end", timeout_s)


def vehicle_with_mission(tmp_path, rows: list[tuple]):
    """A lockstep vehicle on the ground (MPC) with `rows` uploaded as its mission, its ground station connected."""
    sitl = start_sitl(tmp_path / "params.json", speed=None)
    try:
        sitl.gs.connect()
        assert MissionClient(sitl.gs).upload(M.MAV_MISSION_TYPE_MISSION, rows) == M.MAV_MISSION_ACCEPTED
    except BaseException:
        sitl.kill()
        raise
    return sitl


@pytest.mark.timeout(600)  # about 130 s alone on 2 cores; a clean-clone CI run beside other flights took over 300 s
def test_a_mission_with_forward_flight_legs_and_no_transition_item_lands_at_home(tmp_path):
    # Out in forward flight and back to land at home (800 m: two cruises, two brakings), low, so the climb and the
    # landing are short.
    legs = [(400.0, 0.0, 12.0)]
    rows = [waypoint(0, 0, 8.0, M.MAV_CMD_NAV_VTOL_TAKEOFF)] + [waypoint(*leg) for leg in legs] + [
        waypoint(0.0, 0.0, 0.0, M.MAV_CMD_NAV_VTOL_LAND)]  # fmt: skip
    sitl = vehicle_with_mission(tmp_path, rows)
    try:
        gs = sitl.gs
        gs.pump(0.2)
        assert gs.set_mode(MISSION_MODE).result == M.MAV_RESULT_ACCEPTED
        assert gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: gs.armed and gs.altitude > 1.0, "the mission's takeoff", 120)
        closest = [math.inf] * len(legs)
        fastest = [0.0]
        reached: set[int] = set()

        def sample(position) -> None:
            for i, (n, e, _) in enumerate(legs):
                closest[i] = min(closest[i], math.hypot(position.x - n, position.y - e))
            fastest[0] = max(fastest[0], math.hypot(position.vx, position.vy))
            if "MISSION_ITEM_REACHED" in gs.latest:
                reached.add(gs.latest["MISSION_ITEM_REACHED"].seq)

        fly(sitl, lambda: not gs.armed, 900, sample)
        final = gs.latest["LOCAL_POSITION_NED"]
        landing_error = math.hypot(final.x, final.y)
        print(f"waypoint closest approach {closest} m, fastest {fastest[0]:.1f} m/s, "
              f"landed {landing_error:.2f} m from home")  # fmt: skip
        assert all(distance <= 10.0 for distance in closest)
        assert fastest[0] > 20.0  # the legs were flown in forward flight
        assert landing_error <= 2.0
        assert 1 in reached
        gs.wait(lambda: gs.latest["MISSION_CURRENT"].mission_state == M.MISSION_STATE_COMPLETE, "mission complete", 30)
        assert gs.latest["HEARTBEAT"].custom_mode == MISSION_MODE
    finally:
        sitl.kill()


def test_a_mission_without_takeoff_item_started_on_the_ground_climbs_over_home_then_flies_it(tmp_path):
    rows = [waypoint(12.0, 0.0, 6.0), waypoint(12.0, 0.0, 0.0, M.MAV_CMD_NAV_LAND)]
    sitl = vehicle_with_mission(tmp_path, rows)
    try:
        gs = sitl.gs
        assert gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == M.MAV_RESULT_ACCEPTED
        assert gs.set_mode(MISSION_MODE).result == M.MAV_RESULT_ACCEPTED  # as MAVSDK: arm, then start_mission
        climb_offset = [0.0]
        highest = [0.0]
        reached: set[int] = set()

        def sample(position) -> None:
            if highest[0] < 5.0:  # climbing, before the leg to the waypoint
                climb_offset[0] = max(climb_offset[0], math.hypot(position.x, position.y))
            highest[0] = max(highest[0], -position.z)
            if "MISSION_ITEM_REACHED" in gs.latest:
                reached.add(gs.latest["MISSION_ITEM_REACHED"].seq)

        gs.wait(lambda: gs.altitude > 1.0, "the takeoff before the first waypoint", 60)
        fly(sitl, lambda: not gs.armed, 180, sample)
        final = gs.latest["LOCAL_POSITION_NED"]
        print(f"climbed to {highest[0]:.1f} m within {climb_offset[0]:.2f} m of home, landed at "
              f"({final.x:.1f}, {final.y:.1f})")  # fmt: skip
        assert climb_offset[0] < 2.0 and highest[0] >= 5.0
        assert 0 in reached and math.hypot(final.x - 12.0, final.y) <= 2.0
    finally:
        sitl.kill()


def test_orbit_then_goto_then_return_lands_at_home_and_refusals_say_why(tmp_path):
    sitl = start_sitl(tmp_path / "params.json", spawn_alt=20.0, speed=None)
    try:
        gs = sitl.gs
        gs.connect()
        texts = len(gs.statustexts)
        denied = gs.set_mode(MISSION_MODE)
        assert denied.result == M.MAV_RESULT_DENIED
        said(gs, "no mission", since=texts)  # the reason, for this refusal
        too_wide = gs.command(M.MAV_CMD_DO_ORBIT, 20000.0, 5.0, 0, math.nan, math.nan, math.nan, math.nan)
        assert too_wide.result == M.MAV_RESULT_DENIED
        # Orbit: 20 m clockwise at 5 m/s around here (NaN centre and altitude).
        ack = gs.command(M.MAV_CMD_DO_ORBIT, 20.0, 5.0, 0, math.nan, math.nan, math.nan, math.nan)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: gs.mode == ORBIT_MODE, "Orbit mode")
        start = gs.latest["LOCAL_POSITION_NED"]
        gs.wait_sim(20.0, timeout_s=120)
        now = gs.latest["LOCAL_POSITION_NED"]
        radius = math.hypot(now.x - start.x, now.y - start.y)
        print(f"orbit radius after 20 s: {radius:.1f} m, speed {math.hypot(now.vx, now.vy):.1f} m/s")
        assert 16.0 <= radius <= 24.0 and 3.5 <= math.hypot(now.vx, now.vy) <= 6.5
        # Go-to (MAVSDK goto_location): 80 m north of home at 25 m above home, then Hold there.
        lat, lon = latlon_e7(80.0, 0.0)
        ack = gs.command(M.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, lat * 1e-7, lon * 1e-7, HOME.alt + 25.0)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: gs.mode == HOLD, "Hold after the go-to")  # the HEARTBEAT can come after the ACK
        gs.wait(lambda: math.hypot(gs.latest["LOCAL_POSITION_NED"].x - 80.0, gs.latest["LOCAL_POSITION_NED"].y) < 2.0
                and abs(gs.altitude - 25.0) < 1.0, "arrival at the go-to point", 180)  # fmt: skip
        gs.wait_sim(5.0)
        there = gs.latest["LOCAL_POSITION_NED"]
        assert math.hypot(there.x - 80.0, there.y) < 2.0 and gs.mode == HOLD
        # Return at RTL_RETURN_ALT 30 m: climb, fly home, land, disarm.
        gs.param_set("RTL_RETURN_ALT", 30.0, M.MAV_PARAM_TYPE_REAL32)
        assert gs.command(M.MAV_CMD_NAV_RETURN_TO_LAUNCH).result == M.MAV_RESULT_ACCEPTED
        highest = [0.0]
        fly(sitl, lambda: not gs.armed, 300, lambda position: highest.__setitem__(0, max(highest[0], -position.z)))
        final = gs.latest["LOCAL_POSITION_NED"]
        print(f"Return: highest {highest[0]:.1f} m, landed {math.hypot(final.x, final.y):.2f} m from home")
        assert highest[0] >= 29.0 and math.hypot(final.x, final.y) <= 2.0
        on_ground = gs.command(M.MAV_CMD_DO_ORBIT, 20.0, 5.0, 0, math.nan, math.nan, math.nan, math.nan)
        assert on_ground.result == M.MAV_RESULT_TEMPORARILY_REJECTED
        assert gs.command(M.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, lat * 1e-7, lon * 1e-7,
                          HOME.alt + 25.0).result == M.MAV_RESULT_TEMPORARILY_REJECTED  # fmt: skip
    finally:
        sitl.kill()
