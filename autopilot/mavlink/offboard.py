"""Offboard set-points: SET_POSITION_TARGET_LOCAL_NED and SET_POSITION_TARGET_GLOBAL_INT with velocity fields
(MAVSDK's type_mask 0x9C7), in a local, body or global frame, to typed requests. Anything else is dropped with a
STATUSTEXT saying why; a non-finite velocity never reaches the flight stack."""

from __future__ import annotations

from typing import Any

import numpy as np

from autopilot.mavlink.commands import for_us
from autopilot.mavlink.router import GroundLink
from autopilot.mavlink.statustext import Announcer
from autopilot.requests import OffboardVelocity, RequestHandler
from transport.mavlink import mavlink as M

# frame -> the velocity is in a yaw-rotated (body) frame
LOCAL_FRAMES = {M.MAV_FRAME_LOCAL_NED: False, M.MAV_FRAME_LOCAL_OFFSET_NED: False, M.MAV_FRAME_BODY_NED: True,
                M.MAV_FRAME_BODY_OFFSET_NED: True, M.MAV_FRAME_BODY_FRD: True}  # fmt: skip
GLOBAL_FRAMES = (M.MAV_FRAME_GLOBAL, M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_FRAME_GLOBAL_INT,
                 M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_FRAME_GLOBAL_TERRAIN_ALT,
                 M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT)  # fmt: skip
POSITION_IGNORE = 0b111
VELOCITY_IGNORE = 0b111 << 3


class OffboardService:
    def __init__(self, flight_stack: RequestHandler, announcer: Announcer, *, system_id: int) -> None:
        self.flight_stack = flight_stack
        self.announcer = announcer
        self.system_id = system_id
        self.dropped = 0

    def on_position_target_local(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            return
        body = LOCAL_FRAMES.get(message.coordinate_frame)
        if body is None:
            self._drop(f"frame {message.coordinate_frame} not supported (LOCAL_NED, BODY_NED)")
            return
        self._velocity(message, body)

    def on_position_target_global(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            return
        if message.coordinate_frame not in GLOBAL_FRAMES:
            self._drop(f"frame {message.coordinate_frame} not a global frame")
            return
        self._velocity(message, body=False)

    def _velocity(self, message: Any, body: bool) -> None:
        mask = message.type_mask
        if mask & VELOCITY_IGNORE:
            self._drop("velocity only: type_mask must use vx vy vz")
            return
        if (mask & POSITION_IGNORE) != POSITION_IGNORE:
            self._drop("position set-points not supported: velocity only")
            return
        velocity = np.array([message.vx, message.vy, message.vz], dtype=float)
        if not np.all(np.isfinite(velocity)):
            self._drop("not finite (NaN/Inf)")
            return
        self.flight_stack.handle(OffboardVelocity(velocity, body, message.time_boot_ms))

    def _drop(self, why: str) -> None:
        self.dropped += 1
        self.announcer.say(M.MAV_SEVERITY_WARNING, f"Set-point dropped: {why}", key=f"setpoint:{why}")
