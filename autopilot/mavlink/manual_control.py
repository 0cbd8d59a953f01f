"""MANUAL_CONTROL as PX4 takes it from a ground station's virtual joystick (MAVSDK's manual_control,
QGroundControl): x, y, r -1000..1000, z 0..1000 (500 centre), normalised to `ManualControlInput`. An axis at
INT16_MAX is invalid (MAVLink) and taken as centred; values out of range are clamped and said; a refusal
(COM_RC_IN_MODE takes no MAVLink) is said, at most once a while."""

from __future__ import annotations

from typing import Any

from autopilot.mavlink.router import GroundLink
from autopilot.mavlink.statustext import Announcer
from autopilot.topics.requests import ManualControlInput, RequestHandler
from transport.mavlink import mavlink as M

INVALID_AXIS = 32767  # INT16_MAX


def axis(value: int, low: int, centre: float) -> tuple[float, bool]:
    """An axis scaled to low/1000..1 (INT16_MAX: `centre`); True when it was out of range and clamped."""
    if value == INVALID_AXIS:
        return centre, False
    clamped = min(max(value, low), 1000)
    return clamped / 1000.0, clamped != value


def sticks_from_message(x: int, y: int, z: int, r: int) -> tuple[ManualControlInput, bool]:
    """The sticks of a MANUAL_CONTROL (x pitch, y roll, z throttle, r yaw); True when any was clamped."""
    (pitch, a), (roll, b), (throttle, c), (yaw, d) = axis(x, -1000, 0.0), axis(y, -1000, 0.0), axis(z, 0, 0.5), \
        axis(r, -1000, 0.0)  # fmt: skip
    return ManualControlInput(pitch, roll, throttle, yaw), a or b or c or d


class ManualControlService:
    def __init__(self, flight_stack: RequestHandler, announcer: Announcer, *, system_id: int) -> None:
        self.flight_stack = flight_stack
        self.announcer = announcer
        self.system_id = system_id
        self.clamped = 0

    def on_manual_control(self, link: GroundLink, message: Any) -> None:
        if message.target not in (0, self.system_id):
            return
        sticks, clamped = sticks_from_message(message.x, message.y, message.z, message.r)
        if clamped:
            self.clamped += 1
            self.announcer.say(M.MAV_SEVERITY_WARNING, "MANUAL_CONTROL clamped: x, y, r -1000..1000, z 0..1000",
                               key="manual clamped")  # fmt: skip
        reply = self.flight_stack.handle(sticks)
        if reply is not None and reply[0] != M.MAV_RESULT_ACCEPTED and reply[1]:
            self.announcer.say(M.MAV_SEVERITY_WARNING, reply[1], key="manual refused")
