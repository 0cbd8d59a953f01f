"""Offboard set-points: SET_POSITION_TARGET_LOCAL_NED and SET_POSITION_TARGET_GLOBAL_INT with velocity (MAVSDK's
type_mask 0x9C7), position (0x9F8), or position with a velocity feed-forward, in local, body or global frames,
to typed requests, each with its yaw and/or yaw rate unless the type_mask ignores them (a NaN one is ignored too,
as PX4 does; the yaw is a NED heading in every frame, as PX4 takes it). Acceleration set-points are refused.
Anything refused is dropped with a STATUSTEXT saying why; a non-finite value never reaches the flight stack."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from autopilot.mavlink.commands import for_us
from autopilot.mavlink.global_frames import GLOBAL_FRAMES, altitude_amsl
from autopilot.mavlink.router import GroundLink
from autopilot.mavlink.statustext import Announcer
from autopilot.mavlink.view import StatusView
from autopilot.topics.requests import OffboardPosition, OffboardVelocity, RequestHandler
from autopilot.topics.yaw_setpoint import YawSetpoint
from transport.geodesy import Home, ned_from_geodetic
from transport.mavlink import mavlink as M

# frame -> (position relative to the vehicle, yaw-rotated (body) frame)
LOCAL_FRAMES = {M.MAV_FRAME_LOCAL_NED: (False, False), M.MAV_FRAME_LOCAL_OFFSET_NED: (True, False),
                M.MAV_FRAME_BODY_NED: (True, True), M.MAV_FRAME_BODY_OFFSET_NED: (True, True),
                M.MAV_FRAME_BODY_FRD: (True, True)}  # fmt: skip
POSITION_IGNORE = 0b111
VELOCITY_IGNORE = 0b111 << 3
ACCELERATION_IGNORE = 0b111 << 6
FORCE_SETPOINT = 1 << 9
YAW_IGNORE = M.POSITION_TARGET_TYPEMASK_YAW_IGNORE
YAW_RATE_IGNORE = M.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE


def yaw_setpoint(message: Any) -> YawSetpoint | None:
    """The message's yaw (rad) and yaw rate (rad/s), each unless ignored by the type_mask or NaN; None when neither is
    given. Infinite values are the caller's to refuse."""
    mask = message.type_mask
    heading = None if mask & YAW_IGNORE or math.isnan(message.yaw) else float(message.yaw)
    rate = None if mask & YAW_RATE_IGNORE or math.isnan(message.yaw_rate) else float(message.yaw_rate)
    return None if heading is None and rate is None else YawSetpoint(heading, rate)


class OffboardService:
    def __init__(self, flight_stack: RequestHandler, view: StatusView, announcer: Announcer, *, system_id: int,
                 origin: Home) -> None:  # fmt: skip
        self.flight_stack = flight_stack
        self.view = view
        self.announcer = announcer
        self.system_id = system_id
        self.origin = origin  # of the local frame
        self.dropped = 0

    def on_position_target_local(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            return
        frame = LOCAL_FRAMES.get(message.coordinate_frame)
        if frame is None:
            self._drop(f"frame {message.coordinate_frame} not supported (LOCAL_NED, LOCAL_OFFSET_NED, BODY_NED)")
            return
        relative, body = frame
        self._setpoint(message, np.array([message.x, message.y, message.z], dtype=float), relative, body)

    def on_position_target_global(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            return
        if message.coordinate_frame not in GLOBAL_FRAMES:
            self._drop(f"frame {message.coordinate_frame} not a global frame (GLOBAL_INT, GLOBAL_RELATIVE_ALT_INT)")
            return
        position = None
        if message.type_mask & POSITION_IGNORE != POSITION_IGNORE:
            home = self.view.home
            if home is None:
                self._drop("no vehicle state from the plant yet")
                return
            lat, lon = message.lat_int * 1e-7, message.lon_int * 1e-7
            alt = altitude_amsl(message.coordinate_frame, float(message.alt), home.alt)
            if isinstance(alt, str):
                self._drop(alt)
                return
            if not (np.isfinite(alt) and -90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
                self._drop("position not a place on Earth")
                return
            position = np.array(ned_from_geodetic(self.origin, lat, lon, alt))
        self._setpoint(message, position, relative=False, body=False)

    def _setpoint(self, message: Any, position: np.ndarray | None, relative: bool, body: bool) -> None:
        mask = message.type_mask
        uses_position = mask & POSITION_IGNORE != POSITION_IGNORE
        uses_velocity = mask & VELOCITY_IGNORE != VELOCITY_IGNORE
        if mask & FORCE_SETPOINT or mask & ACCELERATION_IGNORE != ACCELERATION_IGNORE:
            self._drop("acceleration and force set-points not supported: position and/or velocity")
            return
        if (mask & POSITION_IGNORE) not in (0, POSITION_IGNORE) or (mask & VELOCITY_IGNORE) not in (0, VELOCITY_IGNORE):
            self._drop("type_mask must use all three of x y z and of vx vy vz, or none")
            return
        if not (uses_position or uses_velocity):
            self._drop("type_mask ignores position and velocity")
            return
        velocity = np.array([message.vx, message.vy, message.vz], dtype=float) if uses_velocity else np.zeros(3)
        if not np.all(np.isfinite(velocity)) or (uses_position and not np.all(np.isfinite(position))):
            self._drop("not finite (NaN/Inf)")
            return
        yaw = yaw_setpoint(message)
        if yaw is not None and any(math.isinf(value) for value in (yaw.heading or 0.0, yaw.rate or 0.0)):
            self._drop("yaw or yaw rate infinite")
            return
        if uses_position:
            self.flight_stack.handle(OffboardPosition(position, velocity, relative, body, yaw))
        else:
            self.flight_stack.handle(OffboardVelocity(velocity, body, message.time_boot_ms, yaw))

    def _drop(self, why: str) -> None:
        self.dropped += 1
        self.announcer.say(M.MAV_SEVERITY_WARNING, f"Set-point dropped: {why}", key=f"setpoint:{why}")
