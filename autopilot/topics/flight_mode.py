"""A flight mode as ground stations know it: its name and PX4's custom mode (custom_mode = main << 16 | sub << 24,
PX4's px4_custom_mode.h). Each mode declares its own (autopilot/navigator/modes/); the MAVLink services are given
the vehicle's table of them."""

from __future__ import annotations

from dataclasses import dataclass

PX4_MAIN_ALTCTL, PX4_MAIN_POSCTL, PX4_MAIN_AUTO, PX4_MAIN_OFFBOARD = 2, 3, 4, 6
PX4_AUTO_TAKEOFF, PX4_AUTO_LOITER, PX4_AUTO_MISSION, PX4_AUTO_RTL, PX4_AUTO_LAND = 2, 3, 4, 5, 6
PX4_AUTO_FOLLOW_TARGET = 8
PX4_POSCTL_ORBIT = 1  # PX4 reports its Orbit navigation state as POSCTL / ORBIT
PX4_MAIN_NAMES = {1: "MANUAL", 2: "ALTCTL", 3: "POSCTL", 4: "AUTO", 5: "ACRO", 6: "OFFBOARD", 7: "STABILIZED",
                  8: "RATTITUDE"}  # fmt: skip
PX4_AUTO_NAMES = {1: "READY", 2: "TAKEOFF", 3: "LOITER", 4: "MISSION", 5: "RTL", 6: "LAND", 7: "RTGS",
                  8: "FOLLOW_TARGET", 9: "PRECLAND"}  # fmt: skip


@dataclass(frozen=True)
class ModeId:
    """A mode's name (what this vehicle says and its summaries give) and PX4's main and sub mode."""

    name: str
    main: int
    sub: int = 0

    @property
    def custom_mode(self) -> int:
        """HEARTBEAT.custom_mode."""
        return (self.main << 16) | (self.sub << 24)

    def matches(self, main: int, sub: int) -> bool:
        """A SET_MODE or MAV_CMD_DO_SET_MODE for PX4's (main, sub) asks for this mode (PX4 ignores Offboard's sub)."""
        return main == self.main and (sub == self.sub or main == PX4_MAIN_OFFBOARD)


def px4_mode_name(main: int, sub: int) -> str:
    """PX4's name of a custom mode, e.g. AUTO.LOITER, for texts."""
    name = PX4_MAIN_NAMES.get(main, f"main mode {main}")
    if main == PX4_MAIN_AUTO:
        name += "." + PX4_AUTO_NAMES.get(sub, f"sub mode {sub}")
    elif main == PX4_MAIN_POSCTL and sub == PX4_POSCTL_ORBIT:
        name += ".ORBIT"
    return name
