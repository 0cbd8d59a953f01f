"""Offboard attitude through MAVLink (SET_ATTITUDE_TARGET, docs/mavlink.md, "Offboard"), the MPC the
default controller out of the loop while it lasts: a lift-off from the ground on thrust above hover, a roll that
moves the vehicle sideways, body rates, the refusals and clamps, and back to Hold (the MPC flies again). Lockstep."""

from __future__ import annotations

import math

from aircraft.airframe import load_airframe
from aircraft.frames import quaternion_from_euler
from tests.sitl.ground_station import HOLD, OFFBOARD
from tests.sitl.mavlink_sitl import start_sitl
from tests.sitl.test_mavlink_failsafes import set_param
from tests.unit.test_mavlink_offboard_attitude import ATTITUDE_MASK, RATES_MASK
from transport.mavlink import mavlink as M

AIRFRAME = load_airframe()
HOVER = AIRFRAME.hover_thrust_per_rotor / AIRFRAME.thrust_max


def test_offboard_attitude_lifts_off_rolls_turns_and_hands_back_to_the_mpc(tmp_path):
    sitl = start_sitl(tmp_path / "params.json", speed=None)
    try:
        gs = sitl.gs
        gs.connect()
        mav = gs.conn.mav
        target = {"mask": ATTITUDE_MASK, "q": quaternion_from_euler(0.0, 0.0, 0.0), "rates": (0.0, 0.0, 0.0),
                  "thrust": 0.0}  # fmt: skip

        def send() -> None:
            mav.set_attitude_target_send(gs.time_boot_ms, gs.vehicle, 1, target["mask"], target["q"], *target["rates"],
                                         target["thrust"])  # fmt: skip

        set_param(gs, "COM_OF_LOSS_T", 5.0)  # lockstep runs faster than the wall clock the set-points are sent on
        assert gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == M.MAV_RESULT_ACCEPTED
        send()
        gs.pump(0.1)
        assert gs.set_mode(OFFBOARD).result == M.MAV_RESULT_ACCEPTED
        target["thrust"] = HOVER + 0.1
        gs.wait(lambda: gs.altitude > 4.0, "the lift-off on thrust above hover", 60, every=send)
        roll = math.radians(15.0)
        target["q"], target["thrust"] = quaternion_from_euler(roll, 0.0, 0.0), HOVER / math.cos(roll)
        gs.wait_sim(3.0, every=send, timeout_s=60)
        attitude = gs.latest["ATTITUDE"]
        print(f"roll {math.degrees(attitude.roll):.1f} deg, east velocity {gs.velocity[1]:.2f} m/s")
        assert abs(attitude.roll - roll) < math.radians(3.0) and gs.velocity[1] > 1.0  # rolled right: goes east
        # Body rates with the attitude ignored: a yaw rate of 0.3 rad/s, level.
        yaw_before = gs.latest["ATTITUDE"].yaw
        target.update(mask=RATES_MASK, rates=(0.0, 0.0, 0.3), thrust=HOVER)
        gs.wait_sim(2.0, every=send, timeout_s=60)
        change = gs.latest["ATTITUDE"].yaw - yaw_before
        turned = math.atan2(math.sin(change), math.cos(change))
        print(f"turned {math.degrees(turned):.1f} deg in 2 s at 0.3 rad/s")
        assert 0.3 < turned < 0.9
        # Bad input: a NaN quaternion is dropped, a thrust above 1 clamped, both said.
        mav.set_attitude_target_send(gs.time_boot_ms, gs.vehicle, 1, ATTITUDE_MASK, [math.nan, 0, 0, 0], 0, 0, 0, 0.5)
        mav.set_attitude_target_send(gs.time_boot_ms, gs.vehicle, 1, ATTITUDE_MASK, [1, 0, 0, 0], 0, 0, 0, 1.5)
        gs.wait(
            lambda: (
                any("quaternion not finite" in text for text in gs.statustexts)
                and any("Attitude set-point clamped" in text for text in gs.statustexts)
            ),
            "the refusals",
            20,
        )
        assert gs.set_mode(HOLD).result == M.MAV_RESULT_ACCEPTED
        gs.wait_sim(5.0, timeout_s=60)
        print(f"Hold: speed {math.hypot(*gs.velocity):.2f} m/s at {gs.altitude:.1f} m")
        assert gs.armed and gs.mode == HOLD and math.hypot(*gs.velocity) < 1.0
    finally:
        sitl.kill()
