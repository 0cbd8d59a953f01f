"""The parameter protocol: PARAM_REQUEST_LIST / READ / SET answered with PARAM_VALUE (PX4's bytewise int32
encoding, correct param_index and param_count). A change is broadcast on every link, as PX4 does; a refused
one is answered with the unchanged value and a STATUSTEXT saying why."""

from __future__ import annotations

from typing import Any

from autopilot.mavlink.commands import for_us
from autopilot.mavlink.router import GroundLink, Router
from autopilot.mavlink.statustext import Announcer
from autopilot.storage.parameters import MAV_TYPE_OF, ParameterRejected, ParameterStore, decode_value, encode_value
from transport.mavlink import mavlink as M

TAKES_EFFECT_LATER = {"MAV_SYS_ID": "from the next start",
                      "VT_CTRL": "from the next start or takeoff from the ground",
                      "SDLOG_MODE": "from the next start"}  # fmt: skip


class ParameterService:
    def __init__(self, params: ParameterStore, router: Router, announcer: Announcer, *, system_id: int) -> None:
        self.params = params
        self.router = router
        self.announcer = announcer
        self.system_id = system_id
        self._write_error: str | None = None

    def check_saved(self) -> None:
        """Say it once when the parameter file could not be written (and again for each new error)."""
        if self.params.write_error is not self._write_error:
            self._write_error = self.params.write_error
            if self._write_error:
                self.announcer.say(M.MAV_SEVERITY_ERROR, f"Parameters not saved: {self._write_error}")

    def _value(self, link: GroundLink, index: int) -> Any:
        definition = self.params.definitions[index]
        value = encode_value(definition, self.params[definition.name])
        return link.mav.param_value_encode(definition.name.encode(), value, MAV_TYPE_OF[definition.kind],
                                           len(self.params), index)  # fmt: skip

    def on_request_list(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            return
        for index in range(len(self.params)):
            link.queue(self._value(link, index))

    def on_request_read(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            return
        if message.param_index >= 0:
            if message.param_index >= len(self.params):
                self.announcer.say(M.MAV_SEVERITY_WARNING, f"Param read: index {message.param_index} not in "
                                   f"0..{len(self.params) - 1}", key="param_index")  # fmt: skip
                return
            link.queue(self._value(link, message.param_index))
            return
        name = message.param_id
        if name not in self.params.index:
            self.announcer.say(M.MAV_SEVERITY_WARNING, f"Param read: unknown {name!r}", key=f"param_unknown:{name}")
            return
        link.queue(self._value(link, self.params.index[name]))

    def on_set(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            return
        name = message.param_id
        definition = self.params.definition(name)
        if definition is None:
            self.announcer.say(M.MAV_SEVERITY_WARNING, f"Param set: unknown {name!r}", key=f"param_unknown:{name}")
            return
        index = self.params.index[name]
        expected = MAV_TYPE_OF[definition.kind]
        if message.param_type != expected:
            self.announcer.say(M.MAV_SEVERITY_WARNING, f"Param set {name}: type {message.param_type}, need {expected}",
                               key=f"param_type:{name}")  # fmt: skip
            link.queue(self._value(link, index))
            return
        try:
            changed = self.params.set(name, decode_value(definition, message.param_value))
        except ParameterRejected as refusal:
            self.announcer.say(M.MAV_SEVERITY_WARNING, f"Param set refused: {refusal}", key=f"param_refused:{name}")
            link.queue(self._value(link, index))
            return
        if not changed:
            link.queue(self._value(link, index))
            return
        if name in TAKES_EFFECT_LATER:
            self.announcer.say(M.MAV_SEVERITY_INFO, f"{name} = {self.params[name]:g} {TAKES_EFFECT_LATER[name]}")
        for other in self.router.links:
            other.queue(self._value(other, index))
