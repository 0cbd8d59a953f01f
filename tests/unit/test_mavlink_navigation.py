"""Navigation through MAVLink (issue 11 items 2 and 3, docs/missions.md, "Return", "Go-to", "Orbit"):
a mission flown by the unified MPC with no DO_VTOL_TRANSITION (it transitions when the legs ask for cruise speed),
Go-to (DO_REPOSITION) then Return, Orbit; the refusals with their reasons. Lockstep, the default controller."""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigator.guidance import circle_velocity, leg_cruise_speed, leg_velocity
from autopilot.navigator.mission_flight import takeoff_down


# ---- the guidance maths -----------------------------------------------------------------------------------------
def test_leg_velocity_cruises_along_the_leg_converges_to_it_and_brakes_into_its_end():
    start, end = np.zeros(2), np.array([400.0, 0.0])
    cruise = leg_velocity(np.array([100.0, 0.0]), start, end, 26.0, 2.0, 0.95)
    assert np.allclose(cruise, [26.0, 0.0])
    off_line = leg_velocity(np.array([100.0, 10.0]), start, end, 26.0, 2.0, 0.95)
    assert off_line[0] == 26.0 and off_line[1] < -5.0  # back towards the line
    braking = leg_velocity(np.array([384.0, 0.0]), start, end, 26.0, 2.0, 0.95)
    assert math.isclose(braking[0], math.sqrt(2 * 2.0 * 16.0)) and braking[1] == 0.0
    assert (
        leg_cruise_speed(400.0, None, 5.0, 26.0, 2.0) == 26.0 and leg_cruise_speed(100.0, None, 5.0, 26.0, 2.0) == 5.0
    )
    assert leg_cruise_speed(100.0, 12.0, 5.0, 26.0, 2.0) == 12.0
    on_circle = circle_velocity(np.array([20.0, 0.0]), np.zeros(2), 20.0, 5.0, True, 5.0)
    assert np.allclose(on_circle, [0.0, 5.0])  # clockwise seen from above: north -> east
    assert np.allclose(circle_velocity(np.array([20.0, 0.0]), np.zeros(2), 20.0, 5.0, False, 5.0), [0.0, -5.0])


def test_a_mission_started_landed_takes_off_to_its_first_item_or_mis_takeoff_alt():
    assert takeoff_down(-25.0, 0.0, 2.5) == -25.0  # the first waypoint's altitude
    assert takeoff_down(-1.0, 0.0, 2.5) == -2.5  # at least MIS_TAKEOFF_ALT above the ground
