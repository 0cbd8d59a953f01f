"""The paper's experiments with their parameters changed: which parameters each experiment takes, their ranges
and the paper's values, and the Scenario they give (what `vtol campaign` sweeps, docs/campaigns.md).

An experiment given none of its parameters is the paper's own (experiments.SCENARIOS), unchanged.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

from aircraft.failures import Failure, FailureType, FailureUnit
from scenarios.experiments import (
    SCENARIOS,
    Circle,
    Scenario,
    TriggeredFailure,
    ground_speed_reaches,
    servo_reaches,
    yaw_reaches,  # fmt: skip
)
from scenarios.profiles import CIRCLE_RADIUS, CIRCLE_SPEED, CircleProfile


class VariantError(ValueError):
    """A parameter the experiment does not take, or a value out of its range."""


@dataclass(frozen=True)
class Parameter:
    name: str
    low: float
    high: float
    paper: float | None  # the paper's value (None: not part of the paper's experiment)
    meaning: str
    integer: bool = False


DURATION = Parameter("duration_s", 0.1, 3600.0, None, "fly only the first S seconds of the profile")
RADIUS = Parameter("radius_m", 20.0, 2000.0, CIRCLE_RADIUS, "circle radius (m)")
SPEED = Parameter("speed_mps", 5.0, 40.0, CIRCLE_SPEED, "circle speed (m/s)")
TURNS = Parameter("turns", 0.05, 5.0, 1.0, "turns of the circle")
FAILURE_YAW = Parameter("failure_yaw_deg", 0.0, 359.99, 90.0, "the rotor fails when the yaw reaches this (deg)")
ROTOR = Parameter("rotor", 1, 4, 1, "the rotor that fails", integer=True)
JAM = Parameter("jam_deg", -7.0, 95.0, 60.0, "the servo jams at this tilt (deg)")
JAM_SPEED = Parameter(
    "jam_speed_mps",
    0.0,
    40.0,
    None,
    "jam when the ground speed reaches this (m/s); unset: when the servo's command reaches jam_deg",
)
SERVO = Parameter("servo", 1, 4, 1, "the tilt servo that jams", integer=True)

PARAMETERS: dict[str, tuple[Parameter, ...]] = {
    "accel": (DURATION,),
    "accel-decel": (DURATION,),
    "circle": (DURATION, RADIUS, SPEED, TURNS),
    "servo-failure": (DURATION, JAM, JAM_SPEED, SERVO),
    "motor-failure": (DURATION, RADIUS, SPEED, TURNS, FAILURE_YAW, ROTOR),
}
"""Each experiment's parameters."""


def checked_values(name: str, values: Mapping[str, float]) -> dict[str, float]:
    """`values` for experiment `name`, checked (known parameter, number in range, integer where it must be)."""
    if name not in PARAMETERS:
        raise VariantError(f"unknown scenario {name!r}: one of {', '.join(PARAMETERS)}")
    known = {parameter.name: parameter for parameter in PARAMETERS[name]}
    checked = {}
    for key, value in values.items():
        if key not in known:
            raise VariantError(f"scenario {name!r} takes no parameter {key!r}: it takes {', '.join(known)}")
        parameter = known[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise VariantError(f"{key} must be a number, not {value!r}")
        if not parameter.low <= value <= parameter.high:
            raise VariantError(f"{key} = {value!r} is outside {parameter.low:g} .. {parameter.high:g}")
        if parameter.integer and value != int(value):
            raise VariantError(f"{key} must be a whole number, not {value!r}")
        checked[key] = int(value) if parameter.integer else float(value)
    return checked


def _value(values: Mapping[str, float], parameter: Parameter) -> float:
    return values.get(parameter.name, parameter.paper)  # type: ignore[return-value]


def _circle(base: Scenario, values: Mapping[str, float]) -> Scenario:
    profile = CircleProfile(_value(values, SPEED), _value(values, RADIUS), _value(values, TURNS))
    summary = f"2 m/s^2 to {profile.speed:g} m/s, then {profile.turns:g} turn(s) of a {profile.radius:g} m circle"
    return replace(
        base,
        profile=profile,
        duration_s=profile.duration_s,
        circle=Circle(profile.start_s, profile.radius),
        summary=summary,
    )


def _motor_failure(base: Scenario, values: Mapping[str, float]) -> Scenario:
    circled = _circle(base, values)
    rotor, yaw = int(_value(values, ROTOR)), _value(values, FAILURE_YAW)
    failure = TriggeredFailure(Failure(FailureUnit.MOTOR, FailureType.OFF, rotor), yaw_reaches(yaw),
                               f"yaw reaches {yaw:g} deg")  # fmt: skip
    return replace(
        circled, failure=failure, summary=f"{circled.summary}, rotor {rotor} off once the yaw reaches {yaw:g} deg"
    )


def _servo_failure(base: Scenario, values: Mapping[str, float]) -> Scenario:
    servo, jam = int(_value(values, SERVO)), _value(values, JAM)
    if JAM_SPEED.name in values:
        speed = values[JAM_SPEED.name]
        condition, trigger = ground_speed_reaches(speed), f"ground speed reaches {speed:g} m/s"
    else:
        condition, trigger = servo_reaches(servo, jam), f"servo {servo} command reaches {jam:g} deg"
    failure = TriggeredFailure(Failure(FailureUnit.SERVO, FailureType.STUCK, servo, jam), condition, trigger)
    return replace(base, failure=failure, summary=f"accel with servo {servo} stuck at {jam:g} deg once the {trigger}")


def build_scenario(name: str, values: Mapping[str, float]) -> Scenario:
    """Experiment `name` with `values` for some of its parameters (the others at the paper's values); raises
    VariantError. Without values it is the paper's experiment itself."""
    values = checked_values(name, values)
    scenario = SCENARIOS[name]
    shaped = {key: value for key, value in values.items() if key != DURATION.name}
    if shaped:
        shape = {"circle": _circle, "motor-failure": _motor_failure, "servo-failure": _servo_failure}[name]
        scenario = shape(scenario, shaped)
    if DURATION.name in values:
        scenario = replace(scenario, duration_s=min(values[DURATION.name], scenario.duration_s))
    return scenario
