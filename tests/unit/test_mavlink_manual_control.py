"""MANUAL_CONTROL as a virtual RC (docs/mavlink.md, "Modes"): Position (POSCTL) from the ground with the
MPC, the default controller: throttle up lifts off, centred sticks hold the altitude and the position, the pitch
stick flies forward; Altitude (ALTCTL); the manual-control loss failsafe (NAV_RCL_ACT); COM_RC_IN_MODE. Lockstep."""

from __future__ import annotations

import math

from autopilot.mavlink.manual_control import sticks_from_message
from autopilot.navigator.manual_control import climb_stick, deadzone


def test_sticks_are_scaled_as_px4_reads_them():
    sticks, clamped = sticks_from_message(1000, -500, 500, 32767)
    assert (sticks.pitch, sticks.roll, sticks.throttle, sticks.yaw, clamped) == (1.0, -0.5, 0.5, 0.0, False)
    assert sticks_from_message(0, 0, -200, 0) == (sticks_from_message(0, 0, 0, 0)[0], True)
    assert climb_stick(0.5) == 0.0 and climb_stick(1.0) == 1.0 and climb_stick(0.0) == -1.0
    assert deadzone(0.05, 0.1) == 0.0 and deadzone(1.0, 0.1) == 1.0 and math.isclose(deadzone(-0.55, 0.1), -0.5)
