"""What the autopilot knows about failed actuators, and the tilt servos' positions it cannot measure.

A failure the plant accepted (aircraft/failures.py, the one failure vocabulary; the plant applies the same
failure physically in sim_bridge/failures.py) changes the allocator's bounds or columns (docs/autopilot.md)
and the tilt estimate (a stuck servo stays where it stuck).
"""

from __future__ import annotations

import math

import numpy as np

from aircraft.actuators import ALLOCATED_ROTORS, ALLOCATED_SURFACES, ActuatorGroup, group_of, index_in_group
from aircraft.airframe import Airframe
from aircraft.failures import Failure, FailureType
from autopilot.control.allocation import ControlAllocator


class ServoEstimate:
    """Tilt servo positions predicted from their commands with the servo's own dynamics (first order, slew limit)."""

    def __init__(self, airframe: Airframe) -> None:
        self.airframe = airframe
        self.tilt = np.zeros(4)
        self.stuck = np.full(4, np.nan)  # angle (rad) of a stuck servo, NaN when healthy
        self.rate_scale = np.ones(4)

    @property
    def any_stuck(self) -> bool:
        """Whether a servo is stuck (a stuck angle that is not NaN)."""
        return any(angle == angle for angle in self.stuck.tolist())

    def observe(self, index: int, tilt: float) -> None:
        """Servo `index` was found at `tilt` (rad, the failure detector): the estimate goes on from there."""
        self.tilt[index] = tilt

    def advance(self, command: np.ndarray, dt: float) -> np.ndarray:
        """Move the estimate dt seconds towards `command` (rad), at the servo's rate; plain Python floats (hot
        path, 250 Hz)."""
        a = self.airframe
        tilt_min, tilt_max, rate_max, tau = a.tilt_min, a.tilt_max, a.servo_rate_max, a.servo_tau
        tilts = self.tilt.tolist()
        for i, (target, stuck, scale) in enumerate(zip(command.tolist(), self.stuck.tolist(),
                                                       self.rate_scale.tolist())):  # fmt: skip
            if stuck == stuck:  # not NaN: a stuck servo drives to its stuck angle
                target = stuck
            target = tilt_min if target < tilt_min else tilt_max if target > tilt_max else target
            limit = rate_max * scale
            rate = (target - tilts[i]) / tau
            rate = -limit if rate < -limit else limit if rate > limit else rate
            tilts[i] += rate * dt
        self.tilt[:] = tilts
        return self.tilt


class ActuatorHealth:
    """Applies MAV_CMD_INJECT_FAILURE semantics to the allocator and the servo estimate."""

    def __init__(self, airframe: Airframe, allocator: ControlAllocator, servos: ServoEstimate) -> None:
        self.airframe = airframe
        self.allocator = allocator
        self.servos = servos

    def apply(self, failure: Failure) -> None:
        """Record a failure the plant has accepted, on every channel it addresses."""
        for channel in failure.channels:
            group, index = group_of(channel), index_in_group(channel)
            if group is ActuatorGroup.ROTOR:
                self._motor(ALLOCATED_ROTORS.start + index, failure)
            elif group is ActuatorGroup.TILT:
                self._tilt_servo(index, failure)
            else:
                self._surface(ALLOCATED_SURFACES.start + index, failure)

    def _motor(self, index: int, failure: Failure) -> None:
        allocator, kind, value = self.allocator, failure.kind, failure.value
        allocator.clear(index)
        if kind == FailureType.OFF:
            allocator.set_failed(index)
        elif kind == FailureType.STUCK:
            held = allocator.u[index] if math.isnan(value) else value
            allocator.set_actuator_limit(index, held, held)
        elif kind == FailureType.WRONG:
            allocator.set_actuator_limit(index, 0.0, failure.wrong_fraction)

    def _tilt_servo(self, index: int, failure: Failure) -> None:
        servos, kind, value = self.servos, failure.kind, failure.value
        servos.stuck[index] = np.nan
        servos.rate_scale[index] = 1.0
        if kind == FailureType.OFF or (kind == FailureType.STUCK and math.isnan(value)):
            servos.stuck[index] = servos.tilt[index]
        elif kind == FailureType.STUCK:
            servos.stuck[index] = math.radians(value)
        elif kind == FailureType.WRONG:
            servos.rate_scale[index] = failure.wrong_fraction

    def _surface(self, index: int, failure: Failure) -> None:
        allocator, kind, value = self.allocator, failure.kind, failure.value
        allocator.clear(index)
        if kind == FailureType.OFF or (kind == FailureType.STUCK and math.isnan(value)):
            held = allocator.u[index]
            allocator.set_actuator_limit(index, held, held)
        elif kind == FailureType.STUCK:
            held = max(-1.0, min(1.0, value / self.airframe.surface_max_deflection_deg))
            allocator.set_actuator_limit(index, held, held)
        elif kind == FailureType.WRONG:
            allocator.set_effectiveness(index, failure.wrong_fraction)
