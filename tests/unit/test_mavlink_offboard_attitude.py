"""Offboard attitude through MAVLink (SET_ATTITUDE_TARGET, docs/mavlink.md, "Offboard"), the MPC the
default controller out of the loop while it lasts: a lift-off from the ground on thrust above hover, a roll that
moves the vehicle sideways, body rates, the refusals and clamps, and back to Hold (the MPC flies again). Lockstep."""

from __future__ import annotations

import math

from autopilot.mavlink.offboard_attitude import attitude_request
from autopilot.navigator.offboard_setpoint import attitude_in_limits
from autopilot.topics.requests import OffboardAttitude

ATTITUDE_MASK = 0b00000111  # body rates ignored: quaternion + thrust
RATES_MASK = 0b10000000  # attitude ignored: body rates + thrust


def test_type_mask_chooses_attitude_or_rates_and_bad_values_are_refused_or_clamped():
    level = attitude_request(ATTITUDE_MASK, [1.0, 0.0, 0.0, 0.0], [9.0, 9.0, 9.0], 0.5)
    assert isinstance(level, OffboardAttitude) and level.body_rates is None and level.thrust == 0.5
    rates = attitude_request(RATES_MASK | 0b001, [math.nan] * 4, [9.0, 0.2, 0.3], 0.5)  # roll rate ignored
    assert isinstance(rates, OffboardAttitude) and rates.euler is None and list(rates.body_rates) == [0.0, 0.2, 0.3]
    assert "no rotation" in attitude_request(ATTITUDE_MASK, [0.0, 0.0, 0.0, 0.0], [0, 0, 0], 0.5)
    assert "type_mask ignores" in attitude_request(0b11000111, [1, 0, 0, 0], [0, 0, 0], 0.5)
    assert "thrust not finite" in attitude_request(ATTITUDE_MASK, [1, 0, 0, 0], [0, 0, 0], math.inf)
    target, clamped = attitude_in_limits(OffboardAttitude(None, rates.body_rates * 100, 1.5), 0.0)
    assert clamped and target.thrust == 1.0 and max(abs(target.body_rates)) == math.pi
    kept, clamped = attitude_in_limits(OffboardAttitude(level.euler, None, None), 0.6)
    assert not clamped and kept.thrust == 0.6  # thrust ignored: the last one stays
