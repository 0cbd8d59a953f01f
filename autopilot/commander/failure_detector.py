"""The motor check of PX4's FailureDetector, on ESC telemetry: a rotor commanded to spin that does not.

The plant reports each rotor's speed as its ESC would (RAW_RPM, 100 Hz, docs/plant-link.md). A rotor is failed
when, for FD_ACT_MOT_TOUT, its command is at least FD_ACT_MOT_THR of full thrust and its measured speed is below
VT_FD_RPM_RATIO of the speed that command gives in steady state (rotor speed grows with the square root of the
thrust fraction). PX4 compares the ESC's current with the throttle (FD_ACT_MOT_C2T); the plant has no electrical
model of its motors, so the speed stands in for the current. A failed rotor stays failed until disarming
(docs/failures.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from aircraft.rotors import RPM_PER_RAD_S


@dataclass(frozen=True)
class MotorCheck:
    """The check's parameters (autopilot/storage/parameters.py)."""

    min_command: float  # FD_ACT_MOT_THR: thrust fraction from which a rotor is checked
    rpm_ratio: float  # VT_FD_RPM_RATIO: measured / expected speed below which it is failing
    timeout_usec: int  # FD_ACT_MOT_TOUT (ms there): failing this long is a failure


def expected_rpm(command: float, speed_max_rad_s: float) -> float:
    """The steady-state speed (RPM) of a rotor commanded to `command` (thrust fraction 0..1)."""
    return speed_max_rad_s * math.sqrt(max(command, 0.0)) * RPM_PER_RAD_S


def failing(rpm: float, command: float, speed_max_rad_s: float, check: MotorCheck) -> bool:
    """This sample says the rotor does not turn as commanded (a NaN speed, an ESC that cannot tell, counts; a NaN
    command is not checked)."""
    if not command >= check.min_command:
        return False
    return not rpm >= check.rpm_ratio * expected_rpm(command, speed_max_rad_s)


@dataclass
class MotorFailureDetector:
    """Per rotor (0-based ESC index): since when it has been failing, and the rotors found failed."""

    speed_max_rad_s: float
    rotor_count: int
    failed: list[int] = field(default_factory=list)  # in the order they were found
    _failing_since: dict[int, int] = field(default_factory=dict)  # index -> time_usec of the first failing sample

    def sample(self, index: int, rpm: float, command: float, now_usec: int, check: MotorCheck) -> bool:
        """One ESC report; True when it makes rotor `index` failed (once per rotor)."""
        if not 0 <= index < self.rotor_count or index in self.failed:
            return False
        if not failing(rpm, command, self.speed_max_rad_s, check):
            self._failing_since.pop(index, None)
            return False
        since = self._failing_since.setdefault(index, now_usec)
        if now_usec - since < check.timeout_usec:
            return False
        self.failed.append(index)
        del self._failing_since[index]
        return True

    def pause(self) -> None:
        """The check is not running (on the ground, disabled): no rotor is failing from now on."""
        self._failing_since.clear()

    def reset(self) -> None:
        """Disarmed: nothing is failed or failing."""
        self.failed.clear()
        self._failing_since.clear()
