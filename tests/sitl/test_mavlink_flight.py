"""Issue 4 "Done means": a pymavlink ground station flies the vehicle from the ground: arm, takeoff to 20 m, Hold,
OFFBOARD velocity 5 m/s north for 10 s, stop streaming (failsafe to Hold within COM_OF_LOSS_T), land, disarmed
on the ground. The plant runs in real time x5; the ground station reads the simulation clock from telemetry."""

from __future__ import annotations

import math

import pytest

from tests.sitl.ground_station import HOLD, LAND, OFFBOARD, TAKEOFF
from tests.sitl.mavlink_sitl import start_sitl
from transport.geodesy import Home
from transport.mavlink import mavlink as M

HOME_ALT = Home().alt  # PX4 SITL's default home


@pytest.fixture
def ground_start(tmp_path):
    sitl = start_sitl(tmp_path / "params.json", speed=5.0, controller="pid")
    yield sitl
    sitl.kill()


def test_arm_takeoff_hold_offboard_failsafe_land(ground_start):
    sitl = ground_start
    gs = sitl.gs
    gs.connect()
    heartbeat = gs.latest["HEARTBEAT"]
    assert heartbeat.type == M.MAV_TYPE_VTOL_TILTROTOR and heartbeat.autopilot == M.MAV_AUTOPILOT_PX4
    assert not gs.armed and gs.mode == HOLD
    gs.wait(lambda: "SYS_STATUS" in gs.latest and "EXTENDED_SYS_STATE" in gs.latest, "status")
    status = gs.latest["SYS_STATUS"]
    assert status.onboard_control_sensors_health & M.MAV_SYS_STATUS_PREARM_CHECK  # armable
    assert gs.landed_state == M.MAV_LANDED_STATE_ON_GROUND
    assert gs.latest["EXTENDED_SYS_STATE"].vtol_state == M.MAV_VTOL_STATE_MC

    # Arm and take off to 20 m (param7: altitude AMSL).
    assert gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == M.MAV_RESULT_ACCEPTED
    gs.wait(lambda: gs.armed, "armed HEARTBEAT")
    nan = math.nan
    ack = gs.command(M.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, nan, nan, nan, HOME_ALT + 20.0)
    assert ack.result == M.MAV_RESULT_ACCEPTED
    gs.wait(lambda: gs.mode == TAKEOFF, "Takeoff mode")
    gs.wait(lambda: gs.landed_state == M.MAV_LANDED_STATE_TAKEOFF, "landed state TAKEOFF")
    gs.wait(lambda: gs.mode == HOLD, "Hold after the takeoff", timeout_s=40)
    assert gs.altitude == pytest.approx(20.0, abs=0.7)
    gs.wait(lambda: gs.landed_state == M.MAV_LANDED_STATE_IN_AIR, "landed state IN_AIR")
    assert "Takeoff complete: Hold" in gs.statustexts

    # Hold: hovering where the takeoff ended.
    start = gs.latest["LOCAL_POSITION_NED"]
    gs.wait_sim(3.0)
    here = gs.latest["LOCAL_POSITION_NED"]
    assert math.hypot(here.x - start.x, here.y - start.y) < 0.5 and abs(here.z + 20.0) < 0.7
    assert all(abs(v) < 0.3 for v in gs.velocity)

    # OFFBOARD: refused without set-points, accepted with a stream of them.
    assert gs.set_mode(OFFBOARD).result == M.MAV_RESULT_TEMPORARILY_REJECTED
    assert any("Offboard denied" in text for text in gs.statustexts)

    def stream() -> None:
        gs.velocity_setpoint(5.0, 0.0, 0.0)

    stream()
    gs.pump(0.02)
    beats_before = len(gs.heartbeats)
    assert gs.set_mode(OFFBOARD).result == M.MAV_RESULT_ACCEPTED
    entered = gs.sim_time
    gs.wait(lambda: gs.mode == OFFBOARD, "Offboard HEARTBEAT", every=stream)
    # A HEARTBEAT goes out right after a mode change, not at the next 1 Hz beat.
    first_offboard = next(t for t, hb in gs.heartbeats[beats_before:] if hb.custom_mode == OFFBOARD)
    assert first_offboard - entered < 0.1
    gs.wait(lambda: gs.sim_time >= entered + 10.0, "10 s of Offboard", timeout_s=40, every=stream)
    vn, ve, vd = gs.velocity
    assert vn == pytest.approx(5.0, abs=0.3) and abs(ve) < 0.3 and abs(vd) < 0.3
    assert gs.latest["LOCAL_POSITION_NED"].x - start.x > 35.0  # about 45 m north of where it held
    assert abs(gs.altitude - 20.0) < 3.0  # velocity control: the altitude drifts a little while accelerating
    assert gs.mode == OFFBOARD

    # Stop streaming: Hold within COM_OF_LOSS_T (1 s), said by STATUSTEXT.
    stopped = gs.sim_time
    gs.wait(lambda: gs.mode == HOLD, "the failsafe to Hold", timeout_s=20)
    assert gs.sim_time - stopped <= 1.0 + 0.15
    assert any("Offboard lost" in text for text in gs.statustexts)
    gs.wait(lambda: math.hypot(*gs.velocity[0:2]) < 0.3, "Hold to stop the vehicle", timeout_s=30)

    # Land: descend, detect touchdown, disarm on the ground.
    assert gs.command(M.MAV_CMD_NAV_LAND).result == M.MAV_RESULT_ACCEPTED
    gs.wait(lambda: gs.mode == LAND, "Land mode")
    gs.wait(lambda: gs.landed_state == M.MAV_LANDED_STATE_LANDING, "landed state LANDING")
    gs.wait(lambda: not gs.armed, "disarmed after landing", timeout_s=60)
    assert gs.altitude < 0.5
    gs.wait(lambda: gs.landed_state == M.MAV_LANDED_STATE_ON_GROUND, "on the ground")
    assert "Landing detected" in gs.statustexts and "Disarmed after landing" in gs.statustexts

    autopilot, plant = sitl.stop()
    assert autopilot["armed"] is False and autopilot["controllers_started"] == 2  # start, and the takeoff
    assert autopilot["links"]["gcs"]["dropped"] == {}
    assert plant["missed_commands"] == 0
