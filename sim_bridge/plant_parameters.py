"""The plant's parameters on the plant link (transport/plant_parameters.py): the autopilot reads them with
PARAM_REQUEST_LIST or PARAM_REQUEST_READ and sets them with PARAM_SET, addressed to the plant's ids; every request
is answered with PARAM_VALUE (a refused set with the unchanged value and a STATUSTEXT saying why), and a change
applies from the next step on."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from sim_bridge.wind import WindModel
from transport.mavlink import Link
from transport.plant_parameters import BY_NAME, MAV_PARAM_TYPE, PLANT_PARAMETERS, decode, encode, refusal
from transport.wind import Wind, from_velocity


@dataclass
class Answer:
    """What answers one request: PARAM_VALUEs to the sender, and what to say (text, whether it is a refusal)."""

    values: list[Any] = field(default_factory=list)
    said: list[tuple[str, bool]] = field(default_factory=list)


class PlantParameterService:
    def __init__(self, wind_model: WindModel, wind: Wind, link: Link) -> None:
        """`wind`: the wind the command line started with (the parameters' values)."""
        self.wind_model = wind_model
        self.wind = wind
        self.link = link
        self.changes = 0
        self.refusals = 0

    @classmethod
    def for_command_line(cls, wind_ned: tuple[float, float, float], turbulence: float, seed: int,
                         link: Link) -> PlantParameterService:  # fmt: skip
        return cls(WindModel(wind_ned, turbulence, seed), from_velocity(wind_ned[0], wind_ned[1], turbulence, seed),
                   link)  # fmt: skip

    def values(self) -> dict[str, float]:
        return {name: float(value) for name, value in self.wind.parameters().items()}

    def for_plant(self, message: Any) -> bool:
        system, component = self.link.mav.srcSystem, self.link.mav.srcComponent
        return message.target_system in (0, system) and message.target_component in (0, component)

    def answer(self, message: Any) -> Answer:
        """What answers a parameter request (nothing for one addressed to others)."""
        if not self.for_plant(message):
            return Answer()
        kind = message.get_type()
        if kind == "PARAM_REQUEST_LIST":
            return Answer([self._value(index) for index in range(len(PLANT_PARAMETERS))])
        if kind == "PARAM_REQUEST_READ":
            index = message.param_index
            if index < 0:
                parameter = BY_NAME.get(message.param_id)
                index = -1 if parameter is None else PLANT_PARAMETERS.index(parameter)
            return Answer([self._value(index)] if 0 <= index < len(PLANT_PARAMETERS) else [])
        return self._set(message)

    def _set(self, message: Any) -> Answer:
        parameter = BY_NAME.get(message.param_id)
        if parameter is None:
            self.refusals += 1
            return Answer(said=[(f"parameter {message.param_id!r} unknown: the plant has {', '.join(BY_NAME)}", True)])
        index = PLANT_PARAMETERS.index(parameter)
        value = decode(parameter, message.param_value)
        expected = MAV_PARAM_TYPE[parameter.kind]
        why = f"type {message.param_type}, need {expected}" if message.param_type != expected else None
        why = why or refusal(parameter, value)
        if why is not None:
            self.refusals += 1
            return Answer([self._value(index)], [(f"{parameter.name} refused: {why}", True)])
        said = []
        if value != self.values()[parameter.name]:
            self.wind = _with(self.wind, parameter.name, value)
            self.wind_model.set(self.wind)
            self.changes += 1
            w = self.wind
            # within a STATUSTEXT's 50 characters after the plant's "plant: "
            said.append((f"wind from N {w.from_north:g} E {w.from_east:g}, gusts {w.turbulence:g} m/s", False))
        return Answer([self._value(index)], said)

    def _value(self, index: int) -> Any:
        parameter = PLANT_PARAMETERS[index]
        value = encode(parameter, self.values()[parameter.name])
        return self.link.mav.param_value_encode(parameter.name.encode(), value, MAV_PARAM_TYPE[parameter.kind],
                                                len(PLANT_PARAMETERS), index)  # fmt: skip


def _with(wind: Wind, name: str, value: float) -> Wind:
    if name == "SIH_WIND_N":
        return replace(wind, from_north=value)
    if name == "SIH_WIND_E":
        return replace(wind, from_east=value)
    if name == "SIM_WIND_TURB":
        return replace(wind, turbulence=value)
    return replace(wind, seed=int(value))
