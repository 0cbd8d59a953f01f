"""Follow Me (PX4's AUTO.FOLLOW_TARGET): follow the target a ground station reports with FOLLOW_TARGET, at
FLW_TGT_DST and FLW_TGT_FA from it and FLW_TGT_HT up, the nose towards it (navigator/follow_target.py). Before the
first FOLLOW_TARGET it brakes and holds; with none for 3 s it stops where the estimate stopped and holds there, in
the mode, until the target is back. It may be chosen disarmed, but arming in it is refused, as PX4 refuses it."""

from __future__ import annotations

import numpy as np

from autopilot.navigator.follow_target import TargetFollower
from autopilot.navigator.guidance import TICK_S
from autopilot.navigator.mode import OFFBOARD_TAKEOFF_CLIMB, FlightMode, ModeContext
from autopilot.navigator.target_estimator import STALE_USEC, TargetEstimate
from autopilot.topics.flight_mode import PX4_AUTO_FOLLOW_TARGET, PX4_MAIN_AUTO, ModeId
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawSetpoint
from transport.mavlink import mavlink

FOLLOW_TARGET = "Follow Me"
TARGET_LOST = f"Follow Me: no FOLLOW_TARGET for {STALE_USEC / 1e6:g} s, holding at the target's last estimate"


class FollowTargetMode(FlightMode):
    """AUTO.FOLLOW_TARGET: follow the target that FOLLOW_TARGET reports, FLW_TGT_DST from it at FLW_TGT_FA and
    FLW_TGT_HT up, the nose towards it (flown as Offboard's position set-points are)."""

    id = ModeId(FOLLOW_TARGET, PX4_MAIN_AUTO, PX4_AUTO_FOLLOW_TARGET)
    prevents_arming = True

    def __init__(self, context: ModeContext) -> None:
        self.tasks = context.tasks
        self.target = context.target
        self.homes = context.homes
        self.say = context.say
        self.follower = TargetFollower(context.params)
        self._tick_usec: int | None = None
        self._setpoint = np.zeros(3)
        self._stale = False

    def activate(self, state: VehicleState) -> None:
        self.follower.start(state, self.homes.position.down)
        self.tasks.start_hold(state)
        self.tasks.start_tracking(state)
        self._tick_usec = None
        self._stale = False

    def setpoint(self, state: VehicleState) -> np.ndarray:
        if self._tick_usec == state.time_usec:  # asked again this tick (lifts_off, then the tick itself)
            return self._setpoint.copy()
        dt = TICK_S if self._tick_usec is None else (state.time_usec - self._tick_usec) / 1e6
        self._tick_usec = state.time_usec
        estimate = self.target.estimate(state.time_usec)
        self._notice(estimate)
        if estimate is None:  # no target yet: brake and hold
            self.tasks.start_tracking(state)
            self._setpoint = self.tasks.hold(state)
            return self._setpoint.copy()
        follow = self.follower.update(state, estimate, dt)
        if follow.ascend:
            self.tasks.start_tracking(state)
            self._setpoint = follow.feed_forward
        else:
            self._setpoint = self.tasks.track(state, follow.position, follow.feed_forward)
        return self._setpoint.copy()

    def _notice(self, estimate: TargetEstimate | None) -> None:
        stale = estimate is not None and estimate.stale
        if stale and not self._stale:
            self.say(mavlink.MAV_SEVERITY_WARNING, TARGET_LOST)
        self._stale = stale

    def yaw(self, state: VehicleState) -> YawSetpoint | None:
        return YawSetpoint(self.follower.heading)

    def lifts_off(self, state: VehicleState) -> bool:
        return bool(self.setpoint(state)[2] < -OFFBOARD_TAKEOFF_CLIMB)
