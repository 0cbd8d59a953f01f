"""Offboard position set-points through MAVLink, flown by the default controller (the MPC): a position in the local
frame, an offset in the body frame, a global position, and a position with a velocity feed-forward."""

from __future__ import annotations

import math

import pymap3d
import pytest

from tests.sitl.ground_station import HOLD, OFFBOARD
from tests.sitl.mavlink_sitl import start_sitl
from transport.mavlink import mavlink as M

ALTITUDE = 50.0
POSITION_MASK = 0b110111111000  # x y z used; velocity, acceleration, yaw, yaw rate ignored (MAVSDK 0x9F8 with yaw)
POSITION_VELOCITY_MASK = 0b110111000000


@pytest.fixture(scope="module")
def hovering(tmp_path_factory):
    """Spawned hovering at 50 m in Hold, MPC (the default), plant paced at x4, a ground station connected."""
    sitl = start_sitl(tmp_path_factory.mktemp("position") / "params.json", spawn_alt=ALTITUDE, speed=4.0)
    sitl.gs.connect()
    yield sitl
    sitl.kill()


def here(gs) -> tuple[float, float, float]:
    p = gs.latest["LOCAL_POSITION_NED"]
    return p.x, p.y, p.z


def fly_to(gs, send, target: tuple[float, float, float], within_m: float = 1.0, timeout_sim_s: float = 40.0) -> None:
    """Stream `send` at 10 Hz of wall time while in Offboard until the vehicle is within `within_m` of `target` and
    slower than 0.5 m/s."""
    send()
    gs.pump(0.05)
    if gs.mode != OFFBOARD:
        assert gs.set_mode(OFFBOARD).result == M.MAV_RESULT_ACCEPTED
    start = gs.sim_time

    def arrived() -> bool:
        assert gs.sim_time - start < timeout_sim_s, f"not at {target} after {timeout_sim_s} s: at {here(gs)}"
        return math.dist(here(gs), target) < within_m and math.hypot(*gs.velocity) < 0.5

    gs.wait(arrived, f"the vehicle at {target}", timeout_s=120, every=send)


def test_offboard_position_in_local_body_and_global_frames(hovering):
    gs = hovering.gs
    mav = gs.conn.mav
    local = (30.0, -20.0, -60.0)
    fly_to(
        gs,
        lambda: mav.set_position_target_local_ned_send(
            gs.time_boot_ms, gs.vehicle, 1, M.MAV_FRAME_LOCAL_NED, POSITION_MASK, *local, 0, 0, 0, 0, 0, 0, 0, 0
        ),
        local,
    )
    assert gs.mode == OFFBOARD

    # Body frame: an offset from where the vehicle is when the set-point arrives, rotated by its yaw (sent once, so
    # with a long COM_OF_LOSS_T: streaming an offset would move the target each time).
    assert gs.param_set("COM_OF_LOSS_T", 60.0, M.MAV_PARAM_TYPE_REAL32).param_value == 60.0
    start, yaw = here(gs), gs.latest["ATTITUDE"].yaw
    target = (start[0] + 10.0 * math.cos(yaw), start[1] + 10.0 * math.sin(yaw), start[2] + 5.0)
    mav.set_position_target_local_ned_send(gs.time_boot_ms, gs.vehicle, 1, M.MAV_FRAME_BODY_OFFSET_NED, POSITION_MASK,
                                           10.0, 0.0, 5.0, 0, 0, 0, 0, 0, 0, 0, 0)  # fmt: skip
    fly_to(gs, lambda: None, target)
    assert gs.param_set("COM_OF_LOSS_T", 1.0, M.MAV_PARAM_TYPE_REAL32).param_value == 1.0

    # Global frame (altitude above home): back over the start point at 50 m.
    home = gs.latest["HOME_POSITION"]
    lat, lon, _ = pymap3d.ned2geodetic(0.0, 0.0, 0.0, home.latitude * 1e-7, home.longitude * 1e-7, home.altitude * 1e-3)
    fly_to(gs, lambda: mav.set_position_target_global_int_send(
        gs.time_boot_ms, gs.vehicle, 1, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, POSITION_MASK, int(round(lat * 1e7)),
        int(round(lon * 1e7)), ALTITUDE, 0, 0, 0, 0, 0, 0, 0, 0), (0.0, 0.0, -ALTITUDE), within_m=1.5)  # fmt: skip

    # The stream stops: Hold where it is, as for velocity set-points (COM_OF_LOSS_T).
    gs.wait(lambda: gs.mode == HOLD, "the failsafe to Hold", timeout_s=20)


def test_offboard_position_with_velocity_feed_forward_and_bad_ones(hovering):
    gs = hovering.gs
    mav = gs.conn.mav
    texts = len(gs.statustexts)
    for x, vx in ((math.nan, 0.0), (0.0, math.inf)):
        mav.set_position_target_local_ned_send(gs.time_boot_ms, gs.vehicle, 1, M.MAV_FRAME_LOCAL_NED, POSITION_VELOCITY_MASK,
                                               x, 0, -50, vx, 0, 0, 0, 0, 0, 0, 0)  # fmt: skip
    mav.set_position_target_local_ned_send(
        gs.time_boot_ms, gs.vehicle, 1, M.MAV_FRAME_LOCAL_NED, 0b110111111011, 0, 0, -50, 0, 0, 0, 0, 0, 0, 0, 0
    )  # fmt: skip  (z alone)
    for why in ("not finite", "all three of x y z"):
        gs.wait(lambda: any(why in t for t in gs.statustexts[texts:]), f"the drop: {why}")
    target = (-20.0, 15.0, -55.0)
    fly_to(gs, lambda: mav.set_position_target_local_ned_send(gs.time_boot_ms, gs.vehicle, 1, M.MAV_FRAME_LOCAL_NED,
                                                              POSITION_VELOCITY_MASK, *target, 0, 0, 0, 0, 0, 0, 0,
                                                              0), target)  # fmt: skip
