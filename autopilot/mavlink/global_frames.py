"""The altitude of a global position (SET_POSITION_TARGET_GLOBAL_INT, COMMAND_INT's and COMMAND_LONG's params 5-7)
as metres AMSL, as PX4's MAVLink receiver reads it: MAV_FRAME_GLOBAL(_INT) AMSL, GLOBAL_RELATIVE_ALT(_INT) above
home (home now, as the flight stack keeps it: arming and DO_SET_HOME move it), GLOBAL_TERRAIN_ALT(_INT) refused:
there is no terrain estimate here (PX4 drops such a set-point without one)."""

from __future__ import annotations

from transport.mavlink import mavlink as M

AMSL_FRAMES = (M.MAV_FRAME_GLOBAL, M.MAV_FRAME_GLOBAL_INT)
RELATIVE_FRAMES = (M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)
TERRAIN_FRAMES = (M.MAV_FRAME_GLOBAL_TERRAIN_ALT, M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT)
GLOBAL_FRAMES = (*AMSL_FRAMES, *RELATIVE_FRAMES, *TERRAIN_FRAMES)


def altitude_amsl(frame: int | None, altitude: float, home_alt: float) -> float | str:
    """`altitude` in `frame` (None: a COMMAND_LONG, AMSL) in metres AMSL, or why it cannot be turned into one."""
    if frame in TERRAIN_FRAMES:
        return f"frame {frame} (altitude above terrain) not supported: no terrain estimate"
    if frame in RELATIVE_FRAMES:
        return home_alt + altitude
    if frame is None or frame in AMSL_FRAMES:
        return altitude
    return f"frame {frame} is not a global frame (GLOBAL_INT, GLOBAL_RELATIVE_ALT_INT)"
