"""The Follow Me target's estimate (PX4's TargetEstimator): an alpha-beta-gamma filter of the FOLLOW_TARGET
positions and velocities a ground station sends, in simulation time, with FLW_TGT_RS as its responsiveness and
FLW_TGT_VG scaling its velocity gain.

Between messages the estimate moves on with its velocity and acceleration. A position is fused at most every
0.5 s, a velocity at most every 0.1 s, each only when it changed or the last fusion is twice that old (a phone
repeats its 1 Hz GPS fix). With no message for 3 s the estimate is stale: it stops where it got to (velocity and
acceleration zero) and stays there until the next message.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from autopilot.storage.parameters import ParameterStore

STALE_USEC = 3_000_000  # PX4's GPS_MESSAGE_STALE_TIMEOUT_MS
POSITION_FUSION_USEC = 500_000  # PX4's MINIMUM_TIME_BETWEEN_POS_FUSIONS_MS
VELOCITY_FUSION_USEC = 100_000  # PX4's MINIMUM_TIME_BETWEEN_VEL_FUSIONS_MS
ACCELERATION_LIMIT = 20.0  # m/s^2 (2 g), PX4's ACCELERATION_SATURATION
MIN_RESPONSIVENESS = 0.1  # FLW_TGT_RS is taken as this below it, as PX4 does
CHANGE_EPSILON = 2.0 * float(np.finfo(np.float32).eps)  # a measurement this close to the last one is a repeat
FUSION_DT_LIMITS = (1e-3, 20.0)  # s: the time since the last fusion, bounded as PX4 bounds it


@dataclass(frozen=True)
class FilterGains:
    """The alpha-beta-gamma gains: position fusion (g, h, k) and velocity fusion (g, h)."""

    g_p: float
    h_p: float
    k_p: float
    g_v: float
    h_v: float


def filter_gains(responsiveness: float, velocity_gain: float) -> FilterGains:
    """The gains from FLW_TGT_RS (beta = RS^(1/3), so that the position weight G = 1 - beta^3 = 1 - RS) and
    FLW_TGT_VG (the velocity's beta is VG times the position's)."""
    beta_p = min(max(responsiveness, MIN_RESPONSIVENESS), 1.0) ** (1.0 / 3.0)
    beta_v = velocity_gain * beta_p
    return FilterGains(g_p=1.0 - beta_p**3, h_p=1.5 * (1.0 - beta_p) ** 2 * (1.0 + beta_p),
                       k_p=0.5 * (1.0 - beta_p) ** 3, g_v=1.0 - beta_v**2, h_v=(1.0 - beta_v) ** 2)  # fmt: skip


def can_fuse(measurement: np.ndarray, previous: np.ndarray | None, since_fusion_usec: int, min_usec: int) -> bool:
    """A measurement is fused when the last fusion is at least `min_usec` old and it changed (or that is twice as
    old)."""
    changed = previous is None or float(np.linalg.norm(measurement - previous)) > CHANGE_EPSILON
    return since_fusion_usec > min_usec and (changed or since_fusion_usec > 2 * min_usec)


def fusion_dt(since_fusion_usec: int) -> float:
    return min(max(since_fusion_usec / 1e6, FUSION_DT_LIMITS[0]), FUSION_DT_LIMITS[1])


@dataclass(frozen=True)
class TargetEstimate:
    """The target now: position (m, NED from the local origin), velocity (m/s), acceleration (m/s^2); `stale`: no
    FOLLOW_TARGET for STALE_USEC (the estimate stands still where it got to)."""

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    stale: bool


class TargetEstimator:
    """The filter's state at `state_usec`, moved on to the time asked (estimate) or measured (measure)."""

    def __init__(self, params: ParameterStore) -> None:
        self.params = params
        self.reset()

    def reset(self) -> None:
        """Forget the target (no estimate until the next FOLLOW_TARGET)."""
        self.position: np.ndarray | None = None
        self.velocity = np.zeros(3)
        self.acceleration = np.zeros(3)
        self.state_usec = 0
        self.message_usec = 0  # the last FOLLOW_TARGET taken
        self.position_fusion_usec = 0
        self.velocity_fusion_usec = 0
        self.last_position: np.ndarray | None = None  # the last fused measurements
        self.last_velocity: np.ndarray | None = None
        self.stopped = False  # stale: stands still until the next message

    def _gains(self) -> FilterGains:
        return filter_gains(self.params["FLW_TGT_RS"], self.params["FLW_TGT_VG"])

    def _predict(self, to_usec: int) -> None:
        """Move the state on with constant acceleration to `to_usec`; once stale, it stops at the stale time."""
        if self.position is None or to_usec <= self.state_usec:
            return
        if not self.stopped and to_usec - self.message_usec >= STALE_USEC:
            self._predict_by(self.message_usec + STALE_USEC)
            self.velocity = np.zeros(3)
            self.acceleration = np.zeros(3)
            self.stopped = True
        self._predict_by(to_usec)

    def _predict_by(self, to_usec: int) -> None:
        if self.position is None:
            return
        dt = max(to_usec - self.state_usec, 0) / 1e6
        self.position = self.position + self.velocity * dt + 0.5 * self.acceleration * dt * dt
        self.velocity = self.velocity + self.acceleration * dt
        self.state_usec = max(to_usec, self.state_usec)

    def measure(self, position: np.ndarray, velocity: np.ndarray | None, now_usec: int) -> None:
        """A FOLLOW_TARGET received at `now_usec` (a second one in the same step is a duplicate, as PX4 drops two
        with the same timestamp)."""
        if self.position is None:
            self.position = position.copy()
            self.velocity = np.zeros(3) if velocity is None else velocity.copy()
            self.acceleration = np.zeros(3)
            self.state_usec = self.message_usec = self.position_fusion_usec = now_usec
            self.last_position = position.copy()
            if velocity is not None:
                self.velocity_fusion_usec = now_usec
                self.last_velocity = velocity.copy()
            return
        if now_usec <= self.message_usec or now_usec <= self.position_fusion_usec:
            return
        self._predict(now_usec)
        self.message_usec = now_usec
        self.stopped = False
        gains = self._gains()
        since = now_usec - self.position_fusion_usec
        if can_fuse(position, self.last_position, since, POSITION_FUSION_USEC):
            dt = fusion_dt(since)
            innovation = position - self.position
            self.position = self.position + gains.g_p * innovation
            self.velocity = self.velocity + gains.h_p / dt * innovation
            self.acceleration = self.acceleration + 2.0 * gains.k_p / (dt * dt) * innovation
            self.position_fusion_usec = now_usec
            self.last_position = position.copy()
        since = now_usec - self.velocity_fusion_usec
        if velocity is not None and can_fuse(velocity, self.last_velocity, since, VELOCITY_FUSION_USEC):
            innovation = velocity - self.velocity
            self.velocity = self.velocity + gains.g_v * innovation
            self.acceleration = self.acceleration + gains.h_v / fusion_dt(since) * innovation
            self.velocity_fusion_usec = now_usec
            self.last_velocity = velocity.copy()
        norm = float(np.linalg.norm(self.acceleration))
        if norm > ACCELERATION_LIMIT:
            self.acceleration = self.acceleration * (ACCELERATION_LIMIT / norm)
        if not all(math.isfinite(v) for v in (*self.position, *self.velocity, *self.acceleration)):
            self.reset()

    def estimate(self, now_usec: int) -> TargetEstimate | None:
        """The target at `now_usec`, None before the first FOLLOW_TARGET."""
        if self.position is None:
            return None
        self._predict(now_usec)
        return TargetEstimate(self.position.copy(), self.velocity.copy(), self.acceleration.copy(), self.stopped)
