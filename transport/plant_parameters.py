"""The plant's parameters (docs/plant-link.md, "The plant's parameters"): the simulated wind, which belongs to the
simulation, not to the vehicle. The plant keeps them (its command line sets them at start); an autopilot reads and
sets them over the plant link with the parameter protocol addressed to the plant's ids (PARAM_REQUEST_LIST,
PARAM_SET, answered with PARAM_VALUE) and shows them among its own (autopilot/commander/plant_parameter_sync.py),
so a ground station sets the wind as it sets any parameter.

Encoding as the autopilot's (PX4's bytewise): a REAL32 travels as its float, an INT32 as the four bytes of the
int32 in the float field.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

INT32, REAL32 = "INT32", "REAL32"
MAV_PARAM_TYPE = {INT32: 6, REAL32: 9}  # MAV_PARAM_TYPE_INT32, MAV_PARAM_TYPE_REAL32
SEED_MAX = 2**31 - 1


@dataclass(frozen=True)
class PlantParameter:
    name: str
    kind: str  # INT32 or REAL32
    default: float
    minimum: float
    maximum: float
    unit: str
    description: str
    px4: bool  # PX4 has the parameter (its SIH simulator's), with this meaning


WIND_MAX = 40.0  # m/s, either component of the mean wind
PLANT_PARAMETERS: tuple[PlantParameter, ...] = (
    PlantParameter("SIH_WIND_N", REAL32, 0.0, -WIND_MAX, WIND_MAX, "m/s",
                   "simulated wind: the mean wind's speed from the north (5: a 5 m/s wind from the north, blowing "
                   "south; PX4's SIH convention)", px4=True),
    PlantParameter("SIH_WIND_E", REAL32, 0.0, -WIND_MAX, WIND_MAX, "m/s",
                   "simulated wind: the mean wind's speed from the east (PX4's SIH convention)", px4=True),
    PlantParameter("SIM_WIND_TURB", REAL32, 0.0, 0.0, 10.0, "m/s",
                   "simulated wind: Dryden turbulence intensity, the vertical gusts' standard deviation (the "
                   "horizontal ones larger by the low-altitude model's ratio; 0: none)", px4=False),
    PlantParameter("SIM_WIND_SEED", INT32, 0, 0, SEED_MAX, "",
                   "simulated wind: the turbulence's random seed (the same seed, the same gusts)", px4=False),
)  # fmt: skip
BY_NAME = {parameter.name: parameter for parameter in PLANT_PARAMETERS}


def encode_bytewise(kind: str, value: float) -> float:
    """The float that carries a parameter of `kind` (INT32 or REAL32) in PARAM_VALUE / PARAM_SET: PX4's bytewise
    encoding, an INT32's bytes as they are."""
    if kind == INT32:
        return struct.unpack("<f", struct.pack("<i", int(value)))[0]
    return float(value)


def decode_bytewise(kind: str, param_value: float) -> float:
    """The value a PARAM_SET / PARAM_VALUE float carries for a parameter of `kind` (a REAL32 as a float32 holds it)."""
    if kind == INT32:
        return float(struct.unpack("<i", struct.pack("<f", param_value))[0])
    return float(struct.unpack("<f", struct.pack("<f", param_value))[0])


def encode(parameter: PlantParameter, value: float) -> float:
    """The float that carries `value` in PARAM_VALUE / PARAM_SET."""
    return encode_bytewise(parameter.kind, value)


def decode(parameter: PlantParameter, param_value: float) -> float:
    """The value a PARAM_SET / PARAM_VALUE float carries."""
    return decode_bytewise(parameter.kind, param_value)


def refusal(parameter: PlantParameter, value: float) -> str | None:
    """Why `value` cannot be the parameter's (None: it can)."""
    if not math.isfinite(value):
        return f"{parameter.name}: {value} is not a finite number"
    if parameter.kind == INT32 and value != int(value):
        return f"{parameter.name}: {value} is not an integer"
    if not parameter.minimum <= value <= parameter.maximum:
        return f"{parameter.name}: {value:g} outside {parameter.minimum:g}..{parameter.maximum:g}"
    return None
