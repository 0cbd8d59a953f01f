"""The mission protocol as far as this vehicle goes today: no stored missions (MISSION_REQUEST_LIST is answered
with MISSION_COUNT 0, an upload of any item is refused with MAV_MISSION_UNSUPPORTED, CLEAR_ALL is accepted), so
QGroundControl and MAVSDK connect without time-outs."""

from __future__ import annotations

from typing import Any

from autopilot.mavlink.commands import for_us
from autopilot.mavlink.router import GroundLink
from autopilot.mavlink.statustext import Announcer
from transport.mavlink import mavlink as M


class MissionService:
    def __init__(self, announcer: Announcer, *, system_id: int) -> None:
        self.announcer = announcer
        self.system_id = system_id

    def on_request_list(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system):
            return
        link.queue(link.mav.mission_count_encode(message.get_srcSystem(), message.get_srcComponent(), 0,
                                                 message.mission_type))  # fmt: skip

    def on_count(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system):
            return
        result = M.MAV_MISSION_ACCEPTED if message.count == 0 else M.MAV_MISSION_UNSUPPORTED
        if message.count:
            self.announcer.say(M.MAV_SEVERITY_WARNING, "Missions not supported: fly with modes and Offboard",
                               key="mission")  # fmt: skip
        self._ack(link, message, result)

    def on_clear_all(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system):
            return
        self._ack(link, message, M.MAV_MISSION_ACCEPTED)

    @staticmethod
    def _ack(link: GroundLink, message: Any, result: int) -> None:
        link.queue(link.mav.mission_ack_encode(message.get_srcSystem(), message.get_srcComponent(), result,
                                               message.mission_type))  # fmt: skip
