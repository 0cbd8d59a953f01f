"""Physical actuator failures, as MAV_CMD_INJECT_FAILURE describes them (SPEC section 5), applied in the plant.

param1 unit: 101 motor (instances 1-4), 102 servo (1-4 tilt servos, 5-8 aileron L, aileron R, elevator,
rudder); param2 type: 0 OK (clears), 1 OFF, 2 STUCK, 4 WRONG; param3 instance (1-based, 0 = all of the
unit); param4 (our extension): for STUCK the angle in degrees (servo, surface) or thrust fraction (motor),
NaN = where it is now; for WRONG the remaining fraction 0..1 (NaN = 0.5).

| unit / type  | OFF                         | STUCK                     | WRONG                     |
| motor        | no thrust at once, no spin  | holds its thrust          | thrust capped at fraction |
| tilt servo   | unpowered: holds its angle  | drives to angle, holds it | slew rate x fraction      |
| surface      | unpowered: holds deflection | drives to angle, holds it | effectiveness x fraction  |
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from aircraft.airframe import Airframe
from transport.mavlink import mavlink
from sim_bridge.dynamics import OVERRIDE_FLAG, OVERRIDE_VALUE, PARAMETER_SIZE, ROTOR_SPEED, SCALE, SURFACE, TILT

UNIT_MOTOR, UNIT_SERVO = mavlink.FAILURE_UNIT_SYSTEM_MOTOR, mavlink.FAILURE_UNIT_SYSTEM_SERVO  # 101, 102
TYPE_OK, TYPE_OFF, TYPE_STUCK, TYPE_WRONG = (
    mavlink.FAILURE_TYPE_OK, mavlink.FAILURE_TYPE_OFF, mavlink.FAILURE_TYPE_STUCK, mavlink.FAILURE_TYPE_WRONG
)  # 0, 1, 2, 4
DEFAULT_WRONG_FRACTION = 0.5
FAILURE_TYPE_NAMES = {TYPE_OK: "OK", TYPE_OFF: "OFF", TYPE_STUCK: "STUCK", TYPE_WRONG: "WRONG"}
ACTUATOR_NAMES = (
    "rotor 1", "rotor 2", "rotor 3", "rotor 4",
    "tilt servo 1", "tilt servo 2", "tilt servo 3", "tilt servo 4",
    "left aileron", "right aileron", "elevator", "rudder",
)  # fmt: skip


class FailureRejected(ValueError):
    """An injection request that cannot be applied; `unsupported` distinguishes UNSUPPORTED from DENIED."""

    def __init__(self, message: str, unsupported: bool = False) -> None:
        super().__init__(message)
        self.unsupported = unsupported


@dataclass
class ActuatorFailures:
    """The failure parameters of the plant's step function, and which actuators are failed how."""

    parameters: np.ndarray = field(default_factory=lambda: healthy_parameters())
    active: dict[int, str] = field(default_factory=dict)  # actuator index -> description

    def clear(self, index: int) -> None:
        self.parameters[OVERRIDE_FLAG][index] = 0.0
        self.parameters[OVERRIDE_VALUE][index] = 0.0
        self.parameters[SCALE][index] = 1.0
        self.active.pop(index, None)


def healthy_parameters(wind_ned: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """Parameter vector of an aircraft with no failure: no overrides, all scales 1."""
    parameters = np.zeros(PARAMETER_SIZE)
    parameters[SCALE] = 1.0
    parameters[36:39] = wind_ned
    return parameters


def actuator_indices(unit: int, instance: int) -> list[int]:
    """Indices (0..11 in the plant's command order) addressed by a unit and a 1-based instance (0 = all)."""
    if unit == UNIT_MOTOR:
        count, offset = 4, 0
    elif unit == UNIT_SERVO:
        count, offset = 8, 4
    else:
        raise FailureRejected(f"failure unit {unit} not simulated (101 motor, 102 servo)", unsupported=True)
    if instance == 0:
        return list(range(offset, offset + count))
    if not 1 <= instance <= count:
        raise FailureRejected(f"instance {instance} out of range 0..{count} for unit {unit}")
    return [offset + instance - 1]


def _integer(value: float, name: str) -> int:
    if not math.isfinite(value) or value != int(value):
        raise FailureRejected(f"{name} must be an integer, got {value}")
    return int(value)


def apply_injection(
    failures: ActuatorFailures,
    airframe: Airframe,
    state: np.ndarray,
    unit_param: float,
    type_param: float,
    instance_param: float,
    extra_param: float,
) -> list[str]:
    """Apply one MAV_CMD_INJECT_FAILURE to the failure set (and the state, for an abrupt rotor stop).

    Returns one human-readable line per affected actuator; raises FailureRejected for bad requests,
    leaving everything unchanged.
    """
    unit = _integer(unit_param, "unit (param1)")
    kind = _integer(type_param, "failure type (param2)")
    instance = _integer(instance_param, "instance (param3)")
    indices = actuator_indices(unit, instance)
    if kind not in FAILURE_TYPE_NAMES:
        raise FailureRejected(f"failure type {kind} not simulated (0 OK, 1 OFF, 2 STUCK, 4 WRONG)", unsupported=True)
    if kind == TYPE_WRONG:
        fraction = DEFAULT_WRONG_FRACTION if math.isnan(extra_param) else extra_param
        if not 0.0 <= fraction <= 1.0:
            raise FailureRejected(f"WRONG needs a remaining fraction in 0..1 (param4), got {extra_param}")
    if kind == TYPE_STUCK and not math.isnan(extra_param):
        for index in indices:
            _stuck_value(airframe, state, index, extra_param)  # validates before anything changes
    lines = []
    for index in indices:
        name = ACTUATOR_NAMES[index]
        if kind == TYPE_OK:
            failures.clear(index)
            lines.append(f"{name}: failure cleared")
            continue
        failures.clear(index)
        if kind == TYPE_OFF:
            value = 0.0 if index < 4 else _current_value(airframe, state, index)
            failures.parameters[OVERRIDE_FLAG][index] = 1.0
            failures.parameters[OVERRIDE_VALUE][index] = value
            if index < 4:
                failures.parameters[SCALE][index] = 0.0
                state[ROTOR_SPEED][index] = 0.0  # abrupt stop: the paper drops the spin rate to 0 %
            description = "OFF"
        elif kind == TYPE_STUCK:
            value = _stuck_value(airframe, state, index, extra_param)
            failures.parameters[OVERRIDE_FLAG][index] = 1.0
            failures.parameters[OVERRIDE_VALUE][index] = value
            description = f"STUCK at {_describe_value(index, value)}"
        else:
            failures.parameters[SCALE][index] = fraction
            description = f"WRONG, {fraction:.0%} left"
        failures.active[index] = description
        lines.append(f"{name}: {description}")
    return lines


def _current_value(airframe: Airframe, state: np.ndarray, index: int) -> float:
    """The actuator's present position in command units."""
    if index < 4:
        return float((state[ROTOR_SPEED][index] / airframe.rotor_speed_max) ** 2)
    if index < 8:
        return float(state[TILT][index - 4])
    return float(state[SURFACE][index - 8])


def _stuck_value(airframe: Airframe, state: np.ndarray, index: int, extra_param: float) -> float:
    """Command-unit value a STUCK failure pins the actuator to (validated)."""
    if math.isnan(extra_param):
        return _current_value(airframe, state, index)
    if not math.isfinite(extra_param):
        raise FailureRejected(f"STUCK value must be finite, got {extra_param}")
    if index < 4:
        if not 0.0 <= extra_param <= 1.0:
            raise FailureRejected(f"a stuck motor's thrust fraction must be in 0..1, got {extra_param}")
        return extra_param
    if index < 8:
        if not airframe.tilt_min_deg <= extra_param <= airframe.tilt_max_deg:
            raise FailureRejected(
                f"stuck tilt {extra_param} deg outside {airframe.tilt_min_deg}..{airframe.tilt_max_deg} deg"
            )
        return math.radians(extra_param)
    limit = airframe.surface_max_deflection_deg
    if abs(extra_param) > limit:
        raise FailureRejected(f"stuck deflection {extra_param} deg outside +-{limit} deg")
    return extra_param / limit


def _describe_value(index: int, value: float) -> str:
    if index < 4:
        return f"{value:.0%} thrust"
    if index < 8:
        return f"{math.degrees(value):.1f} deg"
    return f"deflection {value:+.2f}"
