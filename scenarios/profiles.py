"""The paper's velocity set-point profiles as functions of time t (s) since the profile start.

Each returns the NED velocity set-point (m/s). Used by the autopilot's internal set-point source (before a
ground station streams set-points, `vtol-autopilot --profile`) and by the scenarios (experiments.py).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

ACCEL_TARGET = 27.74  # m/s
CIRCLE_SPEED = 26.0  # m/s
CIRCLE_RADIUS = 250.0  # m
ACCELERATION = 2.0  # m/s^2


def hover(t: float) -> np.ndarray:
    return np.zeros(3)


def accel(t: float) -> np.ndarray:
    """v_x = min(2t, 27.74) (paper eq. for the acceleration test), 25 s."""
    return np.array([min(ACCELERATION * t, ACCEL_TARGET), 0.0, 0.0])


DECEL_CRUISE = 24.0  # m/s, accel-decel's cruise
DECEL_START_S = 15.0  # s, where accel-decel's braking starts


def accel_decel(t: float, deceleration: float = ACCELERATION) -> np.ndarray:
    """v_x = min(2t, 24) up to 15 s, then max(0, 24 - 2 (t - 15)); 32 s. `deceleration` (m/s^2) other than 2 is for
    measuring how fast the aircraft can brake (accel_decel_braking_at; docs/design/alternatives.md, the long horizon)."""
    if t <= DECEL_START_S:
        return np.array([min(ACCELERATION * t, DECEL_CRUISE), 0.0, 0.0])
    return np.array([max(0.0, DECEL_CRUISE - deceleration * (t - DECEL_START_S)), 0.0, 0.0])


def accel_decel_braking_at(deceleration: float) -> Callable[[float], np.ndarray]:
    """accel-decel with its braking at `deceleration` (m/s^2) instead of 2 (benchmarks/bench_horizon.py,
    bench_braking_bound.py --decel)."""
    return functools.partial(accel_decel, deceleration=deceleration)


@dataclass(frozen=True)
class CircleProfile:
    """Accelerate north at 2 m/s^2 to `speed`, then v = speed (cos wt', sin wt', 0), w = speed / radius: `turns`
    clockwise turns (seen from above) of a circle of `radius`. The defaults are the paper's circle."""

    speed: float = CIRCLE_SPEED  # m/s
    radius: float = CIRCLE_RADIUS  # m
    turns: float = 1.0

    @property
    def start_s(self) -> float:
        """Time the circle begins: when the 2 m/s^2 ramp reaches the speed."""
        return self.speed / ACCELERATION

    @property
    def duration_s(self) -> float:
        """The ramp plus the turns, rounded up to 10 ms."""
        return math.ceil((self.start_s + self.turns * 2 * math.pi * self.radius / self.speed) * 100) / 100

    def __call__(self, t: float) -> np.ndarray:
        start = self.start_s
        if t < start:
            return np.array([ACCELERATION * t, 0.0, 0.0])
        angle = self.speed / self.radius * (t - start)
        return np.array([self.speed * math.cos(angle), self.speed * math.sin(angle), 0.0])


PAPER_CIRCLE = CircleProfile()


def circle_start(t: float) -> float:
    """Time the paper's circle begins: when the 2 m/s^2 ramp reaches 26 m/s."""
    return PAPER_CIRCLE.start_s


def circle(t: float) -> np.ndarray:
    """Accelerate north at 2 m/s^2 to 26 m/s, then v = 26 (cos wt', sin wt', 0), w = 26/250, one full turn."""
    return PAPER_CIRCLE(t)


def circle_duration() -> float:
    """The ramp plus one full turn, rounded up to 10 ms."""
    return PAPER_CIRCLE.duration_s


PROFILES: dict[str, tuple[Callable[[float], np.ndarray], float]] = {
    "hover": (hover, 10.0),
    "accel": (accel, 25.0),
    "accel-decel": (accel_decel, 32.0),
    "circle": (circle, circle_duration()),
}
"""Each profile by name: (set-point function, duration in s)."""
