"""PX4's custom modes on MAVLink (custom_mode = main << 16 | sub << 24) for the commander's modes."""

from __future__ import annotations

from autopilot.commander.commander import HOLD, LAND, MISSION, OFFBOARD, ORBIT, RETURN, TAKEOFF
from autopilot.navigator.manual_modes import ALTITUDE, POSITION

PX4_MAIN_ALTCTL, PX4_MAIN_POSCTL, PX4_MAIN_AUTO, PX4_MAIN_OFFBOARD = 2, 3, 4, 6
PX4_AUTO_TAKEOFF, PX4_AUTO_LOITER, PX4_AUTO_MISSION, PX4_AUTO_RTL, PX4_AUTO_LAND = 2, 3, 4, 5, 6
PX4_POSCTL_ORBIT = 1  # PX4 reports its Orbit navigation state as POSCTL / ORBIT (px4_custom_mode.h)
PX4_MODES = {  # mode -> (main mode, sub mode)
    HOLD: (PX4_MAIN_AUTO, PX4_AUTO_LOITER),
    TAKEOFF: (PX4_MAIN_AUTO, PX4_AUTO_TAKEOFF),
    LAND: (PX4_MAIN_AUTO, PX4_AUTO_LAND),
    OFFBOARD: (PX4_MAIN_OFFBOARD, 0),
    MISSION: (PX4_MAIN_AUTO, PX4_AUTO_MISSION),
    RETURN: (PX4_MAIN_AUTO, PX4_AUTO_RTL),
    ORBIT: (PX4_MAIN_POSCTL, PX4_POSCTL_ORBIT),
    POSITION: (PX4_MAIN_POSCTL, 0),
    ALTITUDE: (PX4_MAIN_ALTCTL, 0),
}
PX4_MAIN_NAMES = {1: "MANUAL", 2: "ALTCTL", 3: "POSCTL", 4: "AUTO", 5: "ACRO", 6: "OFFBOARD", 7: "STABILIZED",
                  8: "RATTITUDE"}  # fmt: skip
PX4_AUTO_NAMES = {1: "READY", 2: "TAKEOFF", 3: "LOITER", 4: "MISSION", 5: "RTL", 6: "LAND", 7: "RTGS", 8: "FOLLOW",
                  9: "PRECLAND"}  # fmt: skip


def custom_mode(mode: str) -> int:
    main, sub = PX4_MODES[mode]
    return (main << 16) | (sub << 24)


def mode_from_px4(main: int, sub: int) -> str | None:
    for mode, (m, s) in PX4_MODES.items():
        if m == main and (s == sub or mode == OFFBOARD):
            return mode
    return None


def px4_mode_name(main: int, sub: int) -> str:
    name = PX4_MAIN_NAMES.get(main, f"main mode {main}")
    if main == PX4_MAIN_AUTO:
        name += "." + PX4_AUTO_NAMES.get(sub, f"sub mode {sub}")
    elif main == PX4_MAIN_POSCTL and sub == PX4_POSCTL_ORBIT:
        name += ".ORBIT"
    return name
