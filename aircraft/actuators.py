"""The 12 actuator channels on the wire (SERVO_OUTPUT_RAW, docs/plant-link.md) and their physical meaning.

| channel | actuator          | PWM 1000 ... 2000 maps to                         |
| 1-4     | rotors 1-4        | thrust fraction u = omega^2 / omega_max^2, 0 ... 1 |
| 5-8     | tilt servos 1-4   | tilt chi from tilt_min to tilt_max (-7 ... 95 deg) |
| 9, 10   | ailerons L, R     | deflection -1 ... 1                               |
| 11      | elevator          | -1 ... 1                                          |
| 12      | rudder            | -1 ... 1                                          |

A PWM of 0 means "channel not driven" (PX4's convention for an unused output): a rotor without a
signal stops, a servo or surface without a signal holds where it is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np

from aircraft.airframe import Airframe

CHANNELS = 12
PWM_MIN = 1000
PWM_MAX = 2000
ROTOR_COUNT = 4
# The groups of the 12-channel command order (SERVO_OUTPUT_RAW channels 1-12 are indices 0-11).
ROTORS = slice(0, 4)
TILTS = slice(4, 8)
SURFACES = slice(8, 12)
SERVO_CHANNELS = slice(4, 12)  # what MAV_CMD_INJECT_FAILURE calls servos: tilt servos 1-4, then surfaces 5-8
SERVO_COUNT = SERVO_CHANNELS.stop - SERVO_CHANNELS.start
# The allocator's 8 actuators (rotor thrust fractions, then surfaces); the tilts are not allocated.
ALLOCATED_ROTORS = slice(0, 4)
ALLOCATED_SURFACES = slice(4, 8)
ALLOCATED_COUNT = 8


class ActuatorGroup(Enum):
    """The kinds of actuator channel: rotors, tilt servos, control surfaces."""

    ROTOR = "rotor"
    TILT = "tilt servo"
    SURFACE = "surface"


GROUP_CHANNELS: dict[ActuatorGroup, slice] = {
    ActuatorGroup.ROTOR: ROTORS,
    ActuatorGroup.TILT: TILTS,
    ActuatorGroup.SURFACE: SURFACES,
}
# The group of each channel 0..11, in channel order.
CHANNEL_GROUPS: tuple[ActuatorGroup, ...] = tuple(
    next(group for group, channels in GROUP_CHANNELS.items() if channels.start <= channel < channels.stop)
    for channel in range(CHANNELS)
)
ACTUATOR_NAMES = (
    "rotor 1", "rotor 2", "rotor 3", "rotor 4",
    "tilt servo 1", "tilt servo 2", "tilt servo 3", "tilt servo 4",
    "left aileron", "right aileron", "elevator", "rudder",
)  # fmt: skip


def group_of(channel: int) -> ActuatorGroup:
    """The group (rotor, tilt servo, surface) of a channel 0..11 of the 12-channel command."""
    return CHANNEL_GROUPS[channel]


def index_in_group(channel: int) -> int:
    """A channel's 0-based position within its group: channel 5 (tilt servo 2) is 1."""
    return channel - GROUP_CHANNELS[CHANNEL_GROUPS[channel]].start


def allocated_of(command: np.ndarray) -> np.ndarray:
    """The allocator's 8 actuators (rotors, surfaces) out of a 12-channel command."""
    return np.concatenate((command[ROTORS], command[SURFACES]))


def set_allocated(command: np.ndarray, allocated: np.ndarray) -> None:
    """Write the allocator's 8 actuators into their channels of a 12-channel command (tilts untouched)."""
    command[ROTORS] = allocated[ALLOCATED_ROTORS]
    command[SURFACES] = allocated[ALLOCATED_SURFACES]


@dataclass
class DecodedCommand:
    """Physical actuator commands decoded from PWM."""

    command: np.ndarray  # 12: thrust fractions (4), tilts rad (4), deflections -1..1 (4)
    clamped: int  # channels whose PWM was outside 1000..2000 and got clamped
    undriven: int  # channels with PWM 0


def pwm_to_command(airframe: Airframe, pwm: list[int], previous: np.ndarray) -> DecodedCommand:
    """Decode 12 PWM values into physical commands; undriven servos and surfaces hold `previous`.

    Called for every physics step, hence plain Python rather than numpy (3 us instead of 16 us).
    """
    command = previous.tolist()
    clamped = undriven = 0
    tilt_min, tilt_span = airframe.tilt_min, airframe.tilt_max - airframe.tilt_min
    rotor, tilt = ActuatorGroup.ROTOR, ActuatorGroup.TILT
    for channel, group in enumerate(CHANNEL_GROUPS):
        raw = pwm[channel]
        if raw == 0:
            undriven += 1
            if group is rotor:
                command[channel] = 0.0  # a rotor without a signal stops; servos and surfaces hold
            continue
        if raw < PWM_MIN or raw > PWM_MAX:
            clamped += 1
            raw = PWM_MIN if raw < PWM_MIN else PWM_MAX
        fraction = (raw - PWM_MIN) / (PWM_MAX - PWM_MIN)
        if group is rotor:
            command[channel] = fraction
        elif group is tilt:
            command[channel] = tilt_min + fraction * tilt_span
        else:
            command[channel] = 2.0 * fraction - 1.0
    return DecodedCommand(np.array(command), clamped, undriven)


def command_to_pwm(airframe: Airframe, command: np.ndarray) -> list[int]:
    """Encode physical commands as 12 PWM values (rounded, clamped to 1000..2000; NaN becomes the safe value).

    Safe values: rotors off (1000), servos and surfaces centred on their range. Plain Python: called every step.
    """
    tilt_min, tilt_span = airframe.tilt_min, airframe.tilt_max - airframe.tilt_min
    rotor, tilt = ActuatorGroup.ROTOR, ActuatorGroup.TILT
    pwm = []
    for group, value in zip(CHANNEL_GROUPS, command.tolist()):
        if group is rotor:
            fraction = value
        elif group is tilt:
            fraction = (value - tilt_min) / tilt_span
        else:
            fraction = (value + 1.0) / 2.0
        if not math.isfinite(fraction):
            fraction = 0.0 if group is rotor else 0.5
        fraction = 0.0 if fraction < 0.0 else 1.0 if fraction > 1.0 else fraction
        pwm.append(int(round(PWM_MIN + fraction * (PWM_MAX - PWM_MIN))))
    return pwm
