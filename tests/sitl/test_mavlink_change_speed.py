"""MAV_CMD_DO_CHANGE_SPEED through MAVLink (docs/mavlink.md, "Commands"): a Go-to at the default speed slows to the
commanded speed and goes back to the defaults on -1, as PX4's navigator; a non-finite speed is refused. Lockstep,
the MPC."""

from __future__ import annotations

import math

from tests.sitl.ground_station import HOLD
from tests.sitl.mavlink_sitl import start_sitl
from tests.sitl.test_mavlink_navigation import HOME, latlon_e7
from transport.mavlink import mavlink as M


def test_change_speed_slows_a_goto_and_minus_one_restores_the_default(tmp_path):
    sitl = start_sitl(tmp_path / "params.json", spawn_alt=20.0, speed=None)
    try:
        gs = sitl.gs
        gs.connect()
        assert gs.command(M.MAV_CMD_DO_CHANGE_SPEED, 1, math.nan).result == M.MAV_RESULT_DENIED
        lat, lon = latlon_e7(300.0, 0.0)
        ack = gs.command(M.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, lat * 1e-7, lon * 1e-7, HOME.alt + 20.0)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: gs.mode == HOLD, "Hold")
        assert gs.command(M.MAV_CMD_DO_CHANGE_SPEED, 1, 3.0, -1).result == M.MAV_RESULT_ACCEPTED
        gs.wait_sim(8.0, timeout_s=60)
        slow = math.hypot(*gs.velocity[0:2])
        assert gs.command(M.MAV_CMD_DO_CHANGE_SPEED, 1, -1, -1).result == M.MAV_RESULT_ACCEPTED
        gs.wait_sim(6.0, timeout_s=60)
        default = math.hypot(*gs.velocity[0:2])
        print(f"at 3 m/s: {slow:.2f} m/s; back to the defaults: {default:.2f} m/s")
        assert abs(slow - 3.0) < 0.5 and default > 4.5
        assert any("Speed: 3 m/s" in text for text in gs.statustexts)
    finally:
        sitl.kill()
