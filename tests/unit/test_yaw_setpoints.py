"""Yaw set-points end to end (docs/mavlink.md, Yaw, docs/mavlink.md, "Yaw"): Offboard yaw and yaw rate, a mission
waypoint's param4, DO_REPOSITION's param4, DO_ORBIT's yaw behaviour, the yaw stick, through MAVLink in lockstep,
flown by the default controller (the MPC) and once by the PID; the shaping and the rule of where a yaw is honoured as
pure functions."""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigator.auto_flight import (
    ORBIT_FRONT_TO_CENTER,
    ORBIT_INITIAL_HEADING,
    ORBIT_TANGENT,
    Circle,
    orbit_yaw,
)
from autopilot.navigator.yaw_shaping import YAW_STOPPED, StickYaw, YawShaper, multicopter_speed
from autopilot.topics.yaw_setpoint import YawSetpoint


# ---- the maths ----------------------------------------------------------------------------------------------------
def test_a_heading_is_turned_to_at_the_auto_yaw_rate_and_a_rate_alone_turns_from_the_nose():
    shaper, dt, limit = YawShaper(), 0.01, math.radians(45.0)
    first = shaper.update(YawSetpoint(heading=math.pi / 2), 0.0, limit, dt)
    assert math.isclose(first.yaw, limit * dt) and math.isclose(first.rate, limit)  # one step at 45 deg/s
    for _ in range(300):
        reference = shaper.update(YawSetpoint(heading=math.pi / 2), 0.0, limit, dt)
    assert math.isclose(reference.yaw, math.pi / 2) and reference.rate == 0.0  # arrived, and held
    across = YawShaper().update(YawSetpoint(heading=math.radians(-170.0)), math.radians(170.0), limit, dt)
    assert across.yaw > math.radians(170.0)  # the short way round, through 180 deg, within pi of the nose
    turning = shaper.update(YawSetpoint(rate=0.5), 1.0, limit, dt)
    assert (turning.yaw, turning.rate) == (1.0, 0.5)
    fast = YawShaper().update(YawSetpoint(heading=1.0, rate=2.0), 0.0, limit, dt)
    assert math.isclose(fast.yaw, 0.02)  # a heading with a faster feed-forward moves at that rate
    assert shaper.update(None, 0.0, limit, dt) is None and shaper.reference is None
    assert multicopter_speed(np.array([3.0, 4.0, -2.0]), 5.0) and not multicopter_speed(np.array([12.1, 0, 0]), 12.0)


def test_the_yaw_stick_turns_at_its_rate_and_locks_the_heading_once_the_nose_has_stopped():
    stick = StickYaw()
    stick.reset(0.3)
    assert stick.update(0.0, 0.31, 0.0) == YawSetpoint(0.3)  # centred from the start: the heading it was reset to
    assert stick.update(0.5, 0.4, 0.2) == YawSetpoint(rate=0.5)  # out: its rate, from the nose
    assert stick.update(0.0, 0.6, 2 * YAW_STOPPED) == YawSetpoint(rate=0.0)  # centred, the nose still turning
    assert stick.update(0.0, 0.62, YAW_STOPPED / 2) == YawSetpoint(0.6)  # stopped: locked where it last turned
    assert stick.heading == 0.6


def test_orbit_yaw_behaviours_face_the_centre_the_track_or_the_first_heading():
    circle = Circle(np.zeros(2), -20.0, 20.0, 5.0, True)
    north_of_centre = np.array([20.0, 0.0, -20.0])
    centre = orbit_yaw(circle, north_of_centre)
    assert math.isclose(abs(centre.heading), math.pi) and math.isclose(centre.rate, 0.25)  # south, turning clockwise
    tangent = orbit_yaw(Circle(np.zeros(2), -20.0, 20.0, 5.0, True, ORBIT_TANGENT), north_of_centre)
    assert math.isclose(tangent.heading, math.pi / 2)  # clockwise from the north: flying east
    counter = orbit_yaw(Circle(np.zeros(2), -20.0, 20.0, 5.0, False, ORBIT_TANGENT), north_of_centre)
    assert math.isclose(counter.heading, -math.pi / 2) and math.isclose(counter.rate, -0.25)
    initial = orbit_yaw(Circle(np.zeros(2), -20.0, 20.0, 5.0, True, ORBIT_INITIAL_HEADING, 1.2), north_of_centre)
    assert initial == YawSetpoint(1.2)
    assert orbit_yaw(Circle(np.zeros(2), -20.0, 20.0, 5.0, True, ORBIT_FRONT_TO_CENTER), np.zeros(3)) is None


def test_a_region_of_interest_leaves_takeoffs_landings_and_their_approach_alone():
    from autopilot.navigator.auto_flight import AutoFlight, Climb, FlyTo, HoldAt, LandAt
    from autopilot.storage.parameters import ParameterStore
    from autopilot.topics.region_of_interest import RegionOfInterest
    from autopilot.topics.vehicle_state import VehicleState

    state = VehicleState(time_usec=1, valid=True)
    state.position_ned[:] = (0.0, 0.0, -20.0)
    auto = AutoFlight(ParameterStore(None))
    east = np.array([0.0, 40.0])
    for target, expected in ((FlyTo(np.array([20.0, 0.0, -20.0]), 2.0, yaw=1.0), math.pi / 2),  # the ROI's bearing
                             (HoldAt(np.array([0.0, 0.0, -20.0]), None, 1.0), math.pi / 2),
                             (Climb(np.zeros(2), -30.0, 1.5, 1.0), 1.0),  # a takeoff: its own yaw
                             (FlyTo(np.array([20.0, 0.0, -20.0]), 1.0, yaw=1.0, approach=True), 1.0),
                             (LandAt(np.array([20.0, 0.0]), 1.0), 1.0)):  # fmt: skip
        auto.start(state, [target])
        auto.point_at(RegionOfInterest(east))
        yaw = auto.yaw(state)
        assert yaw is not None and yaw.heading is not None and math.isclose(yaw.heading, expected), target
    auto.start(state, [FlyTo(np.array([20.0, 0.0, -20.0]), 2.0)])
    auto.point_at(RegionOfInterest(None, math.radians(30.0)))  # ROI_WPNEXT: the target, plus the offset
    wpnext = auto.yaw(state)
    assert wpnext is not None and wpnext.heading is not None and math.isclose(wpnext.heading, math.radians(30.0))
