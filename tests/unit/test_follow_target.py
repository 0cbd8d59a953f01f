"""Follow Me without processes (docs/mavlink.md, "Follow Me"): the target estimator (PX4's alpha-beta-gamma filter,
its staleness), the follower's set-points (climb first, then the follow position, the nose at the target), the
mode's entry and arming rules, and FOLLOW_TARGET's checks."""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.commander.commander import ACCEPTED, DENIED, Commander, build_commander
from autopilot.mavlink.follow_target import follow_target_refusal, target_velocity
from autopilot.navigator.follow_target import orbit_step
from autopilot.navigator.guidance import TICK_S
from autopilot.navigator.modes.follow_target import FOLLOW_TARGET, TARGET_LOST
from autopilot.navigator.target_estimator import TargetEstimator, filter_gains
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.requests import FollowTargetReport
from autopilot.topics.vehicle_state import VehicleState

HOVER = 0.69
SPEED = 3.0  # m/s north: the target


def usec(t_s: float) -> int:
    return int(round(t_s * 1e6))


def target_at(t_s: float) -> np.ndarray:
    return np.array([SPEED * t_s, 0.0, 0.0])


def test_the_gains_follow_flw_tgt_rs_and_flw_tgt_vg_as_px4s():
    gains = filter_gains(0.1, 0.9)
    assert gains.g_p == pytest.approx(0.9)  # G = 1 - beta^3 = 1 - RS
    assert filter_gains(0.0, 0.9) == gains  # below 0.1 taken as 0.1
    beta_v = 0.9 * 0.1 ** (1 / 3)
    assert gains.g_v == pytest.approx(1 - beta_v**2) and gains.h_v == pytest.approx((1 - beta_v) ** 2)
    assert filter_gains(1.0, 0.9).g_p == pytest.approx(0.0)  # RS 1: the position is not corrected at all


def test_the_estimate_tracks_a_target_at_constant_speed_and_predicts_between_messages():
    estimator = TargetEstimator(ParameterStore(None))
    assert estimator.estimate(0) is None
    for second in range(10):  # 1 Hz, as MAVSDK and QGroundControl send
        estimator.measure(target_at(second), np.array([SPEED, 0.0, 0.0]), usec(second))
    estimate = estimator.estimate(usec(9.5))
    assert np.allclose(estimate.position, target_at(9.5), atol=0.05)
    assert np.allclose(estimate.velocity, [SPEED, 0.0, 0.0], atol=0.05) and not estimate.stale
    without_velocity = TargetEstimator(ParameterStore(None))
    for second in range(20):  # position only: the filter learns the velocity from the positions
        without_velocity.measure(target_at(second), None, usec(second))
    assert without_velocity.estimate(usec(19)).velocity[0] == pytest.approx(SPEED, abs=0.2)


def test_with_no_message_for_3_s_the_estimate_stops_where_it_got_to_until_the_next():
    estimator = TargetEstimator(ParameterStore(None))
    for second in range(5):
        estimator.measure(target_at(second), np.array([SPEED, 0.0, 0.0]), usec(second))
    assert not estimator.estimate(usec(6.9)).stale
    stopped = estimator.estimate(usec(10.0))
    assert stopped.stale and np.allclose(stopped.velocity, 0.0)
    assert stopped.position[0] == pytest.approx(target_at(7.0)[0], abs=0.05)  # 3 s on from the last message
    assert estimator.estimate(usec(20.0)).position[0] == pytest.approx(stopped.position[0])
    estimator.measure(target_at(21.0), np.array([SPEED, 0.0, 0.0]), usec(21.0))
    assert not estimator.estimate(usec(21.0)).stale
    before = estimator.estimate(usec(21.0)).position.copy()
    estimator.measure(np.array([500.0, 0.0, 0.0]), None, usec(21.0))  # the same step: a duplicate, dropped
    assert np.allclose(estimator.estimate(usec(21.0)).position, before)


def test_the_orbit_angle_turns_the_short_way_at_most_at_its_rate_and_stops_on_the_goal():
    angle, rate = math.radians(170.0), 0.0
    rates = []
    for _ in range(2000):
        angle, rate = orbit_step(angle, rate, math.radians(-170.0), 0.5, 0.25, TICK_S)
        rates.append(rate)
    assert angle == pytest.approx(math.radians(-170.0)) and rate == 0.0
    assert max(rates) <= 0.5 and min(rates) >= 0.0  # through 180 deg (20 deg), not back through 0 (340 deg)


# ---- the mode, through the commander ---------------------------------------------------------------------------------
def state_at(t_s: float, position, velocity=(0.0, 0.0, 0.0), yaw: float = 0.0) -> VehicleState:
    state = VehicleState(time_usec=usec(t_s), valid=True)
    state.position_ned[:] = position
    state.velocity_ned[:] = velocity
    state.euler[2] = yaw
    return state


def flying_commander(**params) -> tuple[Commander, list[str]]:
    store = ParameterStore(None)
    for name, value in params.items():
        store.set(name, value)
    said: list[str] = []
    commander = build_commander(store, HOVER, armed=True, in_air=True, say=lambda severity, text: said.append(text))
    commander.start(state_at(0.0, (0.0, 0.0, -2.0)))
    return commander, said


def test_follow_me_climbs_first_then_follows_behind_the_target_with_the_nose_on_it():
    commander, said = flying_commander()
    start = state_at(0.0, (0.0, 0.0, -2.0))
    commander.tick(start, start.time_usec, HOVER)
    assert commander.set_mode(FOLLOW_TARGET, start) == (ACCEPTED, None)
    # Kinematics only: the vehicle flies its velocity set-point exactly.
    position, velocity = np.array([0.0, 0.0, -2.0]), np.zeros(3)
    heights, gaps = [], []
    t, first_horizontal = 0.0, None
    while t < 60.0:
        t = round(t + TICK_S, 2)
        if abs(t - round(t)) < 1e-9:  # FOLLOW_TARGET at 1 Hz, 20 m ahead, going north at 3 m/s
            commander.follow_target(FollowTargetReport(target_at(t) + [20.0, 0.0, 0.0], np.array([SPEED, 0.0, 0.0])))
        state = state_at(t, position, velocity, yaw=commander.active.yaw(state_at(t, position)).heading
                         if t > TICK_S else 0.0)  # fmt: skip
        setpoint = commander.tick(state, state.time_usec, HOVER)
        if first_horizontal is None and math.hypot(*setpoint[0:2]) > 0.5:
            first_horizontal = -position[2]
        velocity = setpoint
        position = position + velocity * TICK_S
        if t > 40.0:
            heights.append(-position[2])
            gaps.append(target_at(t)[0] + 20.0 - position[0])
    assert commander.mode == FOLLOW_TARGET and TARGET_LOST not in said
    assert first_horizontal > 8.0 - 3.0  # no horizontal flight until within 3 m of FLW_TGT_HT
    assert min(heights) == pytest.approx(8.0, abs=0.1) and max(heights) == pytest.approx(8.0, abs=0.1)
    assert min(gaps) > 8.0 - 0.5 and max(gaps) < 8.0 + 0.5  # FLW_TGT_DST behind (FLW_TGT_FA 180)
    assert abs(position[1]) < 0.1
    assert commander.active.yaw(state_at(t, position)).heading == pytest.approx(0.0, abs=0.01)  # nose north


def test_follow_me_holds_before_the_first_target_and_says_when_the_target_is_lost():
    commander, said = flying_commander()
    here = state_at(0.0, (0.0, 0.0, -8.0))
    commander.tick(here, here.time_usec, HOVER)
    commander.set_mode(FOLLOW_TARGET, here)
    setpoint = commander.tick(state_at(0.01, (0.0, 0.0, -8.0)), usec(0.01), HOVER)
    assert np.allclose(setpoint, 0.0)  # no target yet: hold
    commander.follow_target(FollowTargetReport(np.array([30.0, 0.0, 0.0]), None))
    for t in np.arange(0.02, 3.0, TICK_S):
        commander.tick(state_at(t, (0.0, 0.0, -8.0)), usec(t), HOVER)
    assert TARGET_LOST not in said
    commander.tick(state_at(3.02, (0.0, 0.0, -8.0)), usec(3.02), HOVER)
    assert said.count(TARGET_LOST) == 1 and commander.mode == FOLLOW_TARGET


def test_follow_me_may_be_chosen_disarmed_but_not_armed_in():
    store = ParameterStore(None)
    commander = build_commander(store, HOVER, armed=False, in_air=False)
    ground = state_at(0.0, (0.0, 0.0, 0.0))
    commander.start(ground)
    assert commander.set_mode(FOLLOW_TARGET, ground) == (ACCEPTED, None)
    assert commander.arm(ground) == (DENIED, "Arming denied: Mode not suitable for arming")
    assert commander.arm(ground, force=True)[0] == ACCEPTED


def test_follow_target_messages_are_checked():
    assert follow_target_refusal(47.4, 8.5, 500.0, (1.0, 0.0, 0.0)) is None
    assert follow_target_refusal(91.0, 8.5, 500.0, (0.0, 0.0, 0.0)) == "position not a place on Earth"
    assert follow_target_refusal(47.4, math.nan, 500.0, (0.0, 0.0, 0.0)) == "position not a place on Earth"
    assert follow_target_refusal(47.4, 8.5, math.nan, (0.0, 0.0, 0.0)) == "altitude not finite"
    assert follow_target_refusal(47.4, 8.5, 500.0, (math.inf, 0.0, 0.0)) == "velocity infinite"
    assert target_velocity((math.nan, math.nan, math.nan)) is None  # MAVSDK's unknown velocity: position only
    assert list(target_velocity((1.0, 2.0, 0.0))) == [1.0, 2.0, 0.0]
