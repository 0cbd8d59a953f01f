"""Offboard attitude set-points: SET_ATTITUDE_TARGET (quaternion + thrust, or body rates + thrust, chosen by its
type_mask as PX4 reads it: the attitude when it is not ignored, else the body rates) to `OffboardAttitude`
requests. A non-finite value or a quaternion that is no rotation is dropped with a STATUSTEXT saying why; ranges
are the commander's (clamped and reported there)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from autopilot.mavlink.commands import for_us
from autopilot.mavlink.router import GroundLink
from autopilot.mavlink.statustext import Announcer
from autopilot.topics.requests import OffboardAttitude, RequestHandler
from autopilot.topics.vehicle_state import euler_from_quaternion
from transport.mavlink import mavlink as M

RATES_IGNORE = (M.ATTITUDE_TARGET_TYPEMASK_BODY_ROLL_RATE_IGNORE | M.ATTITUDE_TARGET_TYPEMASK_BODY_PITCH_RATE_IGNORE
                | M.ATTITUDE_TARGET_TYPEMASK_BODY_YAW_RATE_IGNORE)  # fmt: skip
THROTTLE_IGNORE = M.ATTITUDE_TARGET_TYPEMASK_THROTTLE_IGNORE
ATTITUDE_IGNORE = M.ATTITUDE_TARGET_TYPEMASK_ATTITUDE_IGNORE
MIN_QUATERNION_NORM = 0.5  # a quaternion this far from unit length is no rotation (it is normalised otherwise)


def attitude_request(type_mask: int, q: list[float], rates: list[float], thrust: float) -> OffboardAttitude | str:
    """The request a SET_ATTITUDE_TARGET makes, or why it is dropped."""
    uses_attitude = not type_mask & ATTITUDE_IGNORE
    uses_rates = type_mask & RATES_IGNORE != RATES_IGNORE
    uses_thrust = not type_mask & THROTTLE_IGNORE
    if not (uses_attitude or uses_rates or uses_thrust):
        return "type_mask ignores attitude, body rates and thrust"
    if uses_thrust and not math.isfinite(thrust):
        return "thrust not finite (NaN/Inf)"
    euler = body_rates = None
    if uses_attitude:
        if not all(math.isfinite(value) for value in q):
            return "quaternion not finite (NaN/Inf)"
        norm = math.sqrt(sum(value * value for value in q))
        if norm < MIN_QUATERNION_NORM:
            return f"quaternion of norm {norm:.2f} is no rotation"
        euler = np.array(euler_from_quaternion(*(value / norm for value in q)))
    elif uses_rates:
        # PX4 takes the rates whose ignore bit is clear; an ignored axis asks for no rotation about it
        body_rates = np.array([0.0 if type_mask & bit else rate for bit, rate in zip(
            (M.ATTITUDE_TARGET_TYPEMASK_BODY_ROLL_RATE_IGNORE, M.ATTITUDE_TARGET_TYPEMASK_BODY_PITCH_RATE_IGNORE,
             M.ATTITUDE_TARGET_TYPEMASK_BODY_YAW_RATE_IGNORE), rates)])  # fmt: skip
        if not np.all(np.isfinite(body_rates)):
            return "body rates not finite (NaN/Inf)"
    return OffboardAttitude(euler, body_rates, float(thrust) if uses_thrust else None)


class OffboardAttitudeService:
    def __init__(self, flight_stack: RequestHandler, announcer: Announcer, *, system_id: int) -> None:
        self.flight_stack = flight_stack
        self.announcer = announcer
        self.system_id = system_id
        self.dropped = 0

    def on_attitude_target(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            return
        rates = [message.body_roll_rate, message.body_pitch_rate, message.body_yaw_rate]
        request = attitude_request(message.type_mask, list(message.q), rates, message.thrust)
        if isinstance(request, str):
            self.dropped += 1
            self.announcer.say(M.MAV_SEVERITY_WARNING, f"Attitude set-point dropped: {request}",
                               key=f"attitude:{request}")  # fmt: skip
            return
        self.flight_stack.handle(request)
