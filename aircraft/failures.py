"""The failure vocabulary of MAV_CMD_INJECT_FAILURE for this aircraft, written once for plant, autopilot and
ground tools: units, types, instances, the request's checks, and how a failure is said.

param1 unit: 101 motor (instances 1-4, the rotors), 102 servo (1-4 the tilt servos, 5-8 left aileron, right
aileron, elevator, rudder), or a sensor (PX4's FAILURE_UNIT_SENSOR_*: 0 gyro, 1 accel, 2 mag, 3 baro, 4 GPS,
8 airspeed; one instance each); param2 type: 0 OK (clears), 1 OFF, 2 STUCK, 4 WRONG (sensors: OK and OFF);
param3 instance (1-based, 0 = every instance of the unit); param4 (our extension): for STUCK the angle in degrees
(servo, surface) or the thrust fraction (motor), NaN = where it is now; for WRONG the remaining fraction 0..1
(NaN = 0.5).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from enum import IntEnum

from aircraft.actuators import ROTORS, SERVO_CHANNELS


class FailureUnit(IntEnum):
    """MAVLink FAILURE_UNIT values this aircraft simulates."""

    GYRO = 0  # FAILURE_UNIT_SENSOR_GYRO
    ACCEL = 1  # FAILURE_UNIT_SENSOR_ACCEL
    MAG = 2  # FAILURE_UNIT_SENSOR_MAG
    BARO = 3  # FAILURE_UNIT_SENSOR_BARO
    GPS = 4  # FAILURE_UNIT_SENSOR_GPS
    AIRSPEED = 8  # FAILURE_UNIT_SENSOR_AIRSPEED
    MOTOR = 101  # FAILURE_UNIT_SYSTEM_MOTOR
    SERVO = 102  # FAILURE_UNIT_SYSTEM_SERVO


class FailureType(IntEnum):
    """MAVLink FAILURE_TYPE values this aircraft simulates."""

    OK = 0
    OFF = 1
    STUCK = 2
    WRONG = 4


DEFAULT_WRONG_FRACTION = 0.5
SENSORS = frozenset({FailureUnit.GYRO, FailureUnit.ACCEL, FailureUnit.MAG, FailureUnit.BARO, FailureUnit.GPS,
                     FailureUnit.AIRSPEED})  # fmt: skip
SENSOR_TYPES = frozenset({FailureType.OK, FailureType.OFF})
UNIT_NAMES = {FailureUnit.MOTOR: "motor", FailureUnit.SERVO: "servo", FailureUnit.GYRO: "gyro",
              FailureUnit.ACCEL: "accel", FailureUnit.MAG: "mag", FailureUnit.BARO: "baro", FailureUnit.GPS: "GPS",
              FailureUnit.AIRSPEED: "airspeed"}  # fmt: skip
# Instances of each unit, in the order of the 12 actuator channels (aircraft/actuators.py).
UNIT_CHANNELS: dict[FailureUnit, range] = {
    FailureUnit.MOTOR: range(ROTORS.start, ROTORS.stop),
    FailureUnit.SERVO: range(SERVO_CHANNELS.start, SERVO_CHANNELS.stop),
}
UNITS_TEXT = "0 gyro, 1 accel, 2 mag, 3 baro, 4 GPS, 8 airspeed, 101 motor, 102 servo"
TYPES_TEXT = "0 OK, 1 OFF, 2 STUCK, 4 WRONG"


class FailureRejected(ValueError):
    """A failure request that cannot be applied; `unsupported` tells MAV_RESULT_UNSUPPORTED from DENIED."""

    def __init__(self, message: str, unsupported: bool = False) -> None:
        super().__init__(message)
        self.unsupported = unsupported


@dataclass(frozen=True)
class Failure:
    """One checked MAV_CMD_INJECT_FAILURE: unit, type, 1-based instance (0 = all), param4 (may be NaN)."""

    unit: FailureUnit
    kind: FailureType
    instance: int
    value: float = math.nan

    @property
    def sensor(self) -> bool:
        return self.unit in SENSORS

    @property
    def channels(self) -> list[int]:
        """The actuator channels (0..11) the failure addresses (none for a sensor)."""
        if self.sensor:
            return []
        channels = UNIT_CHANNELS[self.unit]
        return list(channels) if self.instance == 0 else [channels[self.instance - 1]]

    @property
    def wrong_fraction(self) -> float:
        """WRONG: the remaining fraction (param4, NaN = DEFAULT_WRONG_FRACTION)."""
        return DEFAULT_WRONG_FRACTION if math.isnan(self.value) else self.value

    def describe(self) -> str:
        """In words, as STATUSTEXT says it: 'servo 1 STUCK at 60 deg', 'motor all OFF', 'motor 2 OK (cleared)'."""
        what = f"{UNIT_NAMES[self.unit]} {self.instance if self.instance else 'all'}"
        if self.kind == FailureType.OK:
            return f"{what} OK (cleared)"
        extra = ""
        if not math.isnan(self.value):
            if self.kind == FailureType.STUCK and self.unit == FailureUnit.SERVO:
                extra = f" at {self.value:g} deg"
            elif self.kind == FailureType.WRONG:
                extra = f" x{self.value:g}"
            else:
                extra = f" {self.value:g}"
        return f"{what} {self.kind.name}{extra}"

    def as_params(self) -> tuple[float, float, float, float]:
        """MAV_CMD_INJECT_FAILURE param1..param4."""
        return float(self.unit), float(self.kind), float(self.instance), self.value


def _integer(value: float, name: str) -> int:
    if not math.isfinite(value) or value != int(value):
        raise FailureRejected(f"{name} must be an integer, got {value:g}")
    return int(value)


def parse_failure(unit: float, kind: float, instance: float, value: float) -> Failure:
    """MAV_CMD_INJECT_FAILURE's param1..param4 checked against the vocabulary; raises FailureRejected.

    What depends on the airframe (a stuck angle inside the tilt range) is checked where the failure is applied."""
    unit_number = _integer(unit, "unit (param1)")
    kind_number = _integer(kind, "failure type (param2)")
    instance_number = _integer(instance, "instance (param3)")
    if unit_number not in UNIT_NAMES:
        raise FailureRejected(f"failure unit {unit_number} not simulated ({UNITS_TEXT})", unsupported=True)
    if kind_number not in FailureType._value2member_map_:
        raise FailureRejected(f"failure type {kind_number} not simulated ({TYPES_TEXT})", unsupported=True)
    failure_unit = FailureUnit(unit_number)
    if failure_unit in SENSORS and kind_number not in SENSOR_TYPES:
        raise FailureRejected(f"failure type {kind_number} not simulated for sensors (0 OK, 1 OFF)", unsupported=True)
    count = 1 if failure_unit in SENSORS else len(UNIT_CHANNELS[failure_unit])
    if not 0 <= instance_number <= count:
        raise FailureRejected(f"{UNIT_NAMES[failure_unit]} instance {instance_number} not in 0..{count}")
    if math.isinf(value):
        raise FailureRejected("param4 must be finite or NaN")
    failure = Failure(failure_unit, FailureType(kind_number), instance_number, value)
    if failure.kind == FailureType.WRONG and not 0.0 <= failure.wrong_fraction <= 1.0:
        raise FailureRejected(f"WRONG needs a remaining fraction in 0..1 (param4), got {value:g}")
    return failure


def failed_sensors(failures: Iterable[Failure]) -> frozenset[FailureUnit]:
    """The sensors OFF after these failures, in the order they were applied (OK clears)."""
    failed: set[FailureUnit] = set()
    for failure in failures:
        if failure.sensor:
            if failure.kind == FailureType.OFF:
                failed.add(failure.unit)
            else:
                failed.discard(failure.unit)
    return frozenset(failed)


def failed_actuators(failures: Iterable[Failure]) -> frozenset[int]:
    """The actuator channels (0..11) failed after these failures, in the order they were applied (OK clears)."""
    failed: set[int] = set()
    for failure in failures:
        channels = set(failure.channels)
        failed = failed - channels if failure.kind == FailureType.OK else failed | channels
    return frozenset(failed)
