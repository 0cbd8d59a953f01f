"""Actuator failures applied physically in the plant: what a checked MAV_CMD_INJECT_FAILURE does to the step
function's parameters (override flags and values, scales) and to the state (a rotor switched off stops at
once), the checks that depend on the airframe, and how an applied failure is announced.

The request's vocabulary (units, types, instances, param4, the checks that do not depend on the airframe)
is aircraft/failures.py; what each failure does to each actuator is in docs/model.md, "Failures".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from aircraft.actuators import ACTUATOR_NAMES, ActuatorGroup, group_of, index_in_group
from aircraft.airframe import Airframe
from aircraft.failures import Failure, FailureRejected, FailureType
from sim_bridge.dynamics import (
    OVERRIDE_FLAG,
    OVERRIDE_VALUE,
    PARAMETER_SIZE,
    ROTOR_SPEED,
    SCALE,
    SURFACE,
    TILT,
    WIND,
)


@dataclass
class ActuatorFailures:
    """The failure parameters of the plant's step function, and which actuators are failed how."""

    parameters: np.ndarray = field(default_factory=lambda: healthy_parameters())
    active: dict[int, str] = field(default_factory=dict)  # actuator channel -> description

    def clear(self, channel: int) -> None:
        self.parameters[OVERRIDE_FLAG][channel] = 0.0
        self.parameters[OVERRIDE_VALUE][channel] = 0.0
        self.parameters[SCALE][channel] = 1.0
        self.active.pop(channel, None)


def healthy_parameters(wind_ned: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """Parameter vector of an aircraft with no failure: no overrides, all scales 1."""
    parameters = np.zeros(PARAMETER_SIZE)
    parameters[SCALE] = 1.0
    parameters[WIND] = wind_ned
    return parameters


def apply_failure(failures: ActuatorFailures, airframe: Airframe, state: np.ndarray, failure: Failure) -> list[str]:
    """Apply one checked failure to the failure set (and the state, for an abrupt rotor stop).

    Returns one human-readable line per affected actuator; raises FailureRejected when a stuck value does
    not fit the airframe, leaving everything unchanged.
    """
    channels = failure.channels
    if failure.kind == FailureType.STUCK and not math.isnan(failure.value):
        for channel in channels:
            _stuck_value(airframe, state, channel, failure.value)  # validates before anything changes
    lines = []
    for channel in channels:
        failures.clear(channel)
        if failure.kind == FailureType.OK:
            lines.append(f"{ACTUATOR_NAMES[channel]}: failure cleared")
            continue
        description = _fail(failures, airframe, state, channel, failure)
        failures.active[channel] = description
        lines.append(f"{ACTUATOR_NAMES[channel]}: {description}")
    return lines


def _fail(failures: ActuatorFailures, airframe: Airframe, state: np.ndarray, channel: int, failure: Failure) -> str:
    """Set one healthy actuator's failure parameters (OFF, STUCK or WRONG); returns its description."""
    parameters = failures.parameters
    rotor = group_of(channel) is ActuatorGroup.ROTOR
    if failure.kind == FailureType.OFF:
        parameters[OVERRIDE_FLAG][channel] = 1.0
        parameters[OVERRIDE_VALUE][channel] = 0.0 if rotor else _current_value(airframe, state, channel)
        if rotor:
            parameters[SCALE][channel] = 0.0
            state[ROTOR_SPEED][index_in_group(channel)] = 0.0  # abrupt stop: the paper drops the spin rate to 0 %
        return "OFF"
    if failure.kind == FailureType.STUCK:
        value = _stuck_value(airframe, state, channel, failure.value)
        parameters[OVERRIDE_FLAG][channel] = 1.0
        parameters[OVERRIDE_VALUE][channel] = value
        return f"STUCK at {_describe_value(channel, value)}"
    parameters[SCALE][channel] = failure.wrong_fraction
    return f"WRONG, {failure.wrong_fraction:.0%} left"


def _current_value(airframe: Airframe, state: np.ndarray, channel: int) -> float:
    """The actuator's present position in command units."""
    group, index = group_of(channel), index_in_group(channel)
    if group is ActuatorGroup.ROTOR:
        return float((state[ROTOR_SPEED][index] / airframe.rotor_speed_max) ** 2)
    if group is ActuatorGroup.TILT:
        return float(state[TILT][index])
    return float(state[SURFACE][index])


def _stuck_value(airframe: Airframe, state: np.ndarray, channel: int, value: float) -> float:
    """Command-unit value a STUCK failure pins the actuator to (param4 NaN: where it is), checked against the
    airframe: a motor's thrust fraction in 0..1, a tilt within the servo's range, a deflection within the
    surface's maximum."""
    if math.isnan(value):
        return _current_value(airframe, state, channel)
    group = group_of(channel)
    if group is ActuatorGroup.ROTOR:
        if not 0.0 <= value <= 1.0:
            raise FailureRejected(f"a stuck motor's thrust fraction must be in 0..1, got {value}")
        return value
    if group is ActuatorGroup.TILT:
        if not airframe.tilt_min_deg <= value <= airframe.tilt_max_deg:
            raise FailureRejected(
                f"stuck tilt {value} deg outside {airframe.tilt_min_deg}..{airframe.tilt_max_deg} deg"
            )
        return math.radians(value)
    limit = airframe.surface_max_deflection_deg
    if abs(value) > limit:
        raise FailureRejected(f"stuck deflection {value} deg outside +-{limit} deg")
    return value / limit


def _describe_value(channel: int, value: float) -> str:
    """A pinned command value in words: thrust percent, tilt degrees or normalised deflection."""
    group = group_of(channel)
    if group is ActuatorGroup.ROTOR:
        return f"{value:.0%} thrust"
    if group is ActuatorGroup.TILT:
        return f"{math.degrees(value):.1f} deg"
    return f"deflection {value:+.2f}"
