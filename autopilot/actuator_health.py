"""What the autopilot knows about failed actuators, and the tilt servos' positions it cannot measure.

The same failure semantics as the plant (sim_bridge/failures.py, SPEC section 5): a known failure changes the
allocator's bounds or columns (SPEC 4.2) and the tilt estimate (a stuck servo stays where it stuck).
"""

from __future__ import annotations

import math

import numpy as np

from aircraft.airframe import Airframe
from transport.mavlink import mavlink
from autopilot.allocation import ControlAllocator

UNIT_MOTOR, UNIT_SERVO = mavlink.FAILURE_UNIT_SYSTEM_MOTOR, mavlink.FAILURE_UNIT_SYSTEM_SERVO  # 101, 102
TYPE_OK, TYPE_OFF, TYPE_STUCK, TYPE_WRONG = (
    mavlink.FAILURE_TYPE_OK, mavlink.FAILURE_TYPE_OFF, mavlink.FAILURE_TYPE_STUCK, mavlink.FAILURE_TYPE_WRONG
)  # 0, 1, 2, 4


class ServoEstimate:
    """Tilt servo positions predicted from their commands with the servo's own dynamics (first order, slew limit)."""

    def __init__(self, airframe: Airframe) -> None:
        self.airframe = airframe
        self.tilt = np.zeros(4)
        self.stuck = np.full(4, np.nan)  # angle (rad) of a stuck servo, NaN when healthy
        self.rate_scale = np.ones(4)

    def advance(self, command: np.ndarray, dt: float) -> np.ndarray:
        """Move the estimate dt seconds towards `command` (rad), at the servo's rate; plain Python (hot path)."""
        a = self.airframe
        for i, target in enumerate(command.tolist()):
            stuck = self.stuck[i]
            if stuck == stuck:  # not NaN: a stuck servo drives to its stuck angle
                target = stuck
            target = a.tilt_min if target < a.tilt_min else a.tilt_max if target > a.tilt_max else target
            limit = a.servo_rate_max * self.rate_scale[i]
            rate = (target - self.tilt[i]) / a.servo_tau
            rate = -limit if rate < -limit else limit if rate > limit else rate
            self.tilt[i] += rate * dt
        return self.tilt


class ActuatorHealth:
    """Applies MAV_CMD_INJECT_FAILURE semantics to the allocator and the servo estimate."""

    def __init__(self, airframe: Airframe, allocator: ControlAllocator, servos: ServoEstimate) -> None:
        self.airframe = airframe
        self.allocator = allocator
        self.servos = servos

    def apply(self, unit: int, kind: int, instance: int, value: float) -> None:
        """Record a failure the plant has accepted (instance 1-based, 0 = all; value = param4)."""
        count = 4 if unit == UNIT_MOTOR else 8
        instances = range(1, count + 1) if instance == 0 else (instance,)
        for number in instances:
            if unit == UNIT_MOTOR:
                self._motor(number - 1, kind, value)
            elif number <= 4:
                self._tilt_servo(number - 1, kind, value)
            else:
                self._surface(4 + number - 5, kind, value)

    def _motor(self, index: int, kind: int, value: float) -> None:
        allocator = self.allocator
        allocator.clear(index)
        if kind == TYPE_OFF:
            allocator.set_failed(index)
        elif kind == TYPE_STUCK:
            held = allocator.u[index] if math.isnan(value) else value
            allocator.set_actuator_limit(index, held, held)
        elif kind == TYPE_WRONG:
            allocator.set_actuator_limit(index, 0.0, 0.5 if math.isnan(value) else value)

    def _tilt_servo(self, index: int, kind: int, value: float) -> None:
        servos = self.servos
        servos.stuck[index] = np.nan
        servos.rate_scale[index] = 1.0
        if kind == TYPE_OFF or (kind == TYPE_STUCK and math.isnan(value)):
            servos.stuck[index] = servos.tilt[index]
        elif kind == TYPE_STUCK:
            servos.stuck[index] = math.radians(value)
        elif kind == TYPE_WRONG:
            servos.rate_scale[index] = 0.5 if math.isnan(value) else value

    def _surface(self, index: int, kind: int, value: float) -> None:
        allocator = self.allocator
        allocator.clear(index)
        if kind == TYPE_OFF or (kind == TYPE_STUCK and math.isnan(value)):
            held = allocator.u[index]
            allocator.set_actuator_limit(index, held, held)
        elif kind == TYPE_STUCK:
            held = max(-1.0, min(1.0, value / self.airframe.surface_max_deflection_deg))
            allocator.set_actuator_limit(index, held, held)
        elif kind == TYPE_WRONG:
            allocator.set_effectiveness(index, 0.5 if math.isnan(value) else value)
