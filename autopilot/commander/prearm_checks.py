"""PX4's pre-arm checks that this vehicle has (its HealthAndArmingChecks): why an arming is refused, from the
state of the moment. A forced arming (MAV_CMD_COMPONENT_ARM_DISARM param2 21196) skips all of them but the
flight termination."""

from __future__ import annotations

import math

from autopilot.topics.vehicle_state import VehicleState

MAX_LEVEL_TILT = math.radians(30.0)  # arming on the ground: roll and pitch within this


def prearm_refusal(state: VehicleState, *, force: bool, terminated: bool, outside_fence: str | None,
                   mission_invalid: bool, mode_prevents_arming: bool = False) -> str | None:  # fmt: skip
    """Why arming is denied (the STATUSTEXT), or None. `outside_fence`: why the vehicle is outside the geofence;
    `mission_invalid`: in Mission, the mission fails its feasibility check; `mode_prevents_arming`: the chosen mode
    may not be armed in (Follow Me)."""
    if terminated:
        return "Arming denied: flight terminated (MAV_CMD_DO_FLIGHTTERMINATION with param1 0 clears it)"
    if force:
        return None
    roll, pitch = float(state.euler[0]), float(state.euler[1])
    if abs(roll) > MAX_LEVEL_TILT or abs(pitch) > MAX_LEVEL_TILT:
        return f"Arming denied: not level (roll {math.degrees(roll):.0f}, pitch {math.degrees(pitch):.0f} deg)"
    if outside_fence is not None:
        return f"Arming denied: vehicle outside the geofence ({outside_fence})"
    if mission_invalid:
        return "Arming denied: no valid mission"
    if mode_prevents_arming:
        return "Arming denied: Mode not suitable for arming"
    return None
