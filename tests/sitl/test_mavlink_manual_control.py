"""MANUAL_CONTROL as a virtual RC (docs/mavlink.md, "Modes"): Position (POSCTL) from the ground with the
MPC, the default controller: throttle up lifts off, centred sticks hold the altitude and the position, the pitch
stick flies forward; Altitude (ALTCTL); the manual-control loss failsafe (NAV_RCL_ACT); COM_RC_IN_MODE. Lockstep."""

from __future__ import annotations

import math

from tests.sitl.mavlink_sitl import start_sitl
from tests.sitl.test_mavlink_failsafes import set_param
from tests.sitl.test_mavlink_navigation import RETURN_MODE
from transport.mavlink import mavlink as M

POSCTL, ALTCTL = 3 << 16, 2 << 16


def test_position_mode_flies_on_the_sticks_and_manual_control_loss_returns(tmp_path):
    sitl = start_sitl(tmp_path / "params.json", speed=None)
    try:
        gs = sitl.gs
        gs.connect()
        mav = gs.conn.mav
        sticks = {"x": 0, "y": 0, "z": 500, "r": 0}

        def send() -> None:
            mav.manual_control_send(1, sticks["x"], sticks["y"], sticks["z"], sticks["r"], 0)

        set_param(gs, "COM_RC_LOSS_T", 5.0)  # lockstep runs faster than the wall clock the sticks are sent on
        refused = gs.set_mode(POSCTL)
        assert refused.result == M.MAV_RESULT_TEMPORARILY_REJECTED
        gs.wait(lambda: any("no manual control" in text for text in gs.statustexts), "the reason")
        send()
        gs.pump(0.1)
        assert gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == M.MAV_RESULT_ACCEPTED
        assert gs.set_mode(POSCTL).result == M.MAV_RESULT_ACCEPTED
        sticks["z"] = 1000  # full throttle: climb at MPC_Z_VEL_MAX_UP
        gs.wait(lambda: gs.altitude > 6.0, "the lift-off on the throttle", 60, every=send)
        sticks["z"] = 500
        gs.wait_sim(3.0, every=send, timeout_s=60)
        held = gs.altitude
        gs.wait_sim(3.0, every=send, timeout_s=60)
        print(f"altitude held {held:.2f} -> {gs.altitude:.2f} m")
        assert abs(gs.altitude - held) < 0.5
        sticks["x"] = 1000  # full forward: MPC_VEL_MANUAL along the heading when Position began
        gs.wait_sim(4.0, every=send, timeout_s=60)
        speed = math.hypot(*gs.velocity[0:2])
        print(f"full forward stick: {speed:.1f} m/s")
        assert speed > 5.0
        sticks["x"] = 0
        gs.wait_sim(8.0, every=send, timeout_s=60)
        stopped = gs.latest["LOCAL_POSITION_NED"]
        gs.wait_sim(3.0, every=send, timeout_s=60)
        now = gs.latest["LOCAL_POSITION_NED"]
        print(f"centred: moved {math.hypot(now.x - stopped.x, now.y - stopped.y):.2f} m in 3 s")
        assert math.hypot(now.x - stopped.x, now.y - stopped.y) < 0.5 and gs.mode == POSCTL
        assert gs.set_mode(ALTCTL).result == M.MAV_RESULT_ACCEPTED
        gs.wait_sim(1.0, every=send, timeout_s=60)
        assert gs.mode == ALTCTL and gs.armed
        # No more MANUAL_CONTROL: after COM_RC_LOSS_T, NAV_RCL_ACT 2 (Return).
        gs.wait(lambda: gs.mode == RETURN_MODE, "the manual control loss failsafe", 30)
        assert any("Manual control lost" in text for text in gs.statustexts)
        # COM_RC_IN_MODE 4 (manual control disabled): MANUAL_CONTROL is ignored, with a reason.
        set_param(gs, "COM_RC_IN_MODE", 4)
        send()
        gs.wait(lambda: any("MANUAL_CONTROL ignored" in text for text in gs.statustexts), "the refusal")
        assert gs.set_mode(POSCTL).result == M.MAV_RESULT_DENIED
    finally:
        sitl.kill()
