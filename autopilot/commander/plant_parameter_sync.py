"""The plant's parameters (the wind: transport/plant_parameters.py) among the autopilot's, as PX4's SIH keeps its
SIH_WIND_* among its own: a ground station reads and sets them like any parameter, and they reach the plant over
the plant link, addressed to the plant's ids as the failure injection is.

The plant keeps them (its command line sets them at start) and its answer is the truth: when the link starts (and
after the plant restarts) the values are read from it (PARAM_REQUEST_LIST) and shown here; a value a ground station
sets here goes to the plant as PARAM_SET in the same plant step, ahead of that step's SERVO_OUTPUT_RAW, so the
plant applies it before it integrates the step (a set at the same simulation time gives the same flight); the
plant's PARAM_VALUE confirms it (a refusal answers the unchanged value, which is shown again). Nothing the plant has not confirmed is sent, so the defaults shown before the first
answer never overwrite the plant's own values. A request or a set not answered within RESEND_USEC of simulation
time is sent again (a lossy plant link).
"""

from __future__ import annotations

from typing import Any, Protocol

from autopilot.storage.parameters import ParameterRejected, ParameterStore
from transport.plant_parameters import BY_NAME, MAV_PARAM_TYPE, decode, encode

RESEND_USEC = 500_000


class PlantParameterLink(Protocol):
    def request_plant_parameters(self) -> bool: ...

    def set_plant_parameter(self, name: str, param_value: float, param_type: int) -> bool: ...


class PlantParameterSync:
    def __init__(self, params: ParameterStore, link: PlantParameterLink) -> None:
        self.params = params
        self.link = link
        self.confirmed: dict[str, float] = {}  # the plant's values as it last answered
        self.pending: dict[str, tuple[float, int]] = {}  # name -> (value sent, when)
        self._requested_usec: int | None = None
        self.sets_sent = 0

    def restart(self) -> None:
        """A new plant run: its values are read again."""
        self.confirmed.clear()
        self.pending.clear()
        self._requested_usec = None

    def step(self, now_usec: int) -> None:
        """Read the plant's values until it has answered; send what a ground station changed since."""
        unread = len(self.confirmed) < len(BY_NAME)
        due = self._requested_usec is None or now_usec - self._requested_usec >= RESEND_USEC
        if unread and due and self.link.request_plant_parameters():
            self._requested_usec = now_usec
        for name, confirmed in self.confirmed.items():
            value = self.params[name]
            sent = self.pending.get(name)
            if value == confirmed or (sent is not None and sent[0] == value and now_usec - sent[1] < RESEND_USEC):
                continue
            parameter = BY_NAME[name]
            if self.link.set_plant_parameter(name, encode(parameter, value), MAV_PARAM_TYPE[parameter.kind]):
                self.pending[name] = (value, now_usec)
                self.sets_sent += 1

    def answered(self, message: Any) -> str | None:
        """The plant's PARAM_VALUE: its value is the truth, shown here (a set the plant refused is undone). Returns
        why an answer was not taken (a name or value the autopilot does not have)."""
        parameter = BY_NAME.get(message.param_id)
        if parameter is None:
            return f"the plant's parameter {message.param_id!r} is not one of {', '.join(BY_NAME)}"
        value = decode(parameter, message.param_value)
        try:
            self.params.set(parameter.name, value)
        except ParameterRejected as refusal:
            return f"the plant's value refused: {refusal}"
        self.confirmed[parameter.name] = value
        self.pending.pop(parameter.name, None)
        return None
