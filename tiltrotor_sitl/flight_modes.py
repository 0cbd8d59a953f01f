"""PX4's flight modes by name, as ground stations set and show them: HEARTBEAT.custom_mode (PX4's main mode in bits
16-23, its sub mode in bits 24-31, px4_custom_mode.h) and back.

The names are PX4's, in capitals as MAVSDK and PX4's shell write them: "HOLD", "MISSION", "RETURN", "OFFBOARD"...;
QGroundControl's and PX4's other spellings are accepted too ("Hold", "LOITER", "AUTO.LOITER", "RTL", "Position").
This vehicle flies HOLD, TAKEOFF, LAND, OFFBOARD, MISSION, RETURN, FOLLOW_ME, ORBIT, POSCTL and ALTCTL
(docs/mavlink.md); it refuses the others as PX4 refuses a mode it cannot enter.
"""

from __future__ import annotations

from enum import StrEnum

from autopilot.topics.flight_mode import (
    PX4_AUTO_FOLLOW_TARGET,
    PX4_AUTO_LAND,
    PX4_AUTO_LOITER,
    PX4_AUTO_MISSION,
    PX4_AUTO_RTL,
    PX4_AUTO_TAKEOFF,
    PX4_MAIN_ALTCTL,
    PX4_MAIN_AUTO,
    PX4_MAIN_OFFBOARD,
    PX4_MAIN_POSCTL,
    PX4_POSCTL_ORBIT,
)

PX4_MAIN_MANUAL, PX4_MAIN_ACRO, PX4_MAIN_STABILIZED = 1, 5, 7
PX4_AUTO_PRECLAND = 9


class FlightMode(StrEnum):
    """A PX4 flight mode (its value is its name: FlightMode.HOLD == "HOLD")."""

    MANUAL = "MANUAL"
    STABILIZED = "STABILIZED"
    ACRO = "ACRO"
    ALTCTL = "ALTCTL"
    POSCTL = "POSCTL"
    ORBIT = "ORBIT"
    OFFBOARD = "OFFBOARD"
    TAKEOFF = "TAKEOFF"
    HOLD = "HOLD"
    MISSION = "MISSION"
    RETURN = "RETURN"
    LAND = "LAND"
    FOLLOW_ME = "FOLLOW_ME"
    PRECLAND = "PRECLAND"

    @property
    def main_mode(self) -> int:
        return _PX4_MODES[self][0]

    @property
    def sub_mode(self) -> int:
        return _PX4_MODES[self][1]

    @property
    def custom_mode(self) -> int:
        """HEARTBEAT.custom_mode of this mode."""
        return (self.main_mode << 16) | (self.sub_mode << 24)

    @classmethod
    def named(cls, name: str) -> FlightMode:
        """The mode a name means (any of the spellings above, case and "-", " ", "_" aside); ValueError naming the
        modes otherwise."""
        key = name.strip().upper().replace("-", "_").replace(" ", "_")
        mode = _ALIASES.get(key)
        if mode is None:
            modes = ", ".join(member.value for member in cls)
            raise ValueError(f"unknown flight mode {name!r}: PX4's modes are {modes}")
        return mode

    @classmethod
    def of_custom_mode(cls, custom_mode: int) -> FlightMode | None:
        """The mode a HEARTBEAT's custom_mode says (None: one PX4 does not name). Offboard's sub mode is ignored, as
        PX4 ignores it."""
        main, sub = (custom_mode >> 16) & 0xFF, (custom_mode >> 24) & 0xFF
        for mode, (mode_main, mode_sub) in _PX4_MODES.items():
            if main == mode_main and (sub == mode_sub or main == PX4_MAIN_OFFBOARD):
                return mode
        return None


_PX4_MODES: dict[FlightMode, tuple[int, int]] = {
    FlightMode.MANUAL: (PX4_MAIN_MANUAL, 0),
    FlightMode.STABILIZED: (PX4_MAIN_STABILIZED, 0),
    FlightMode.ACRO: (PX4_MAIN_ACRO, 0),
    FlightMode.ALTCTL: (PX4_MAIN_ALTCTL, 0),
    FlightMode.POSCTL: (PX4_MAIN_POSCTL, 0),
    FlightMode.ORBIT: (PX4_MAIN_POSCTL, PX4_POSCTL_ORBIT),
    FlightMode.OFFBOARD: (PX4_MAIN_OFFBOARD, 0),
    FlightMode.TAKEOFF: (PX4_MAIN_AUTO, PX4_AUTO_TAKEOFF),
    FlightMode.HOLD: (PX4_MAIN_AUTO, PX4_AUTO_LOITER),
    FlightMode.MISSION: (PX4_MAIN_AUTO, PX4_AUTO_MISSION),
    FlightMode.RETURN: (PX4_MAIN_AUTO, PX4_AUTO_RTL),
    FlightMode.LAND: (PX4_MAIN_AUTO, PX4_AUTO_LAND),
    FlightMode.FOLLOW_ME: (PX4_MAIN_AUTO, PX4_AUTO_FOLLOW_TARGET),
    FlightMode.PRECLAND: (PX4_MAIN_AUTO, PX4_AUTO_PRECLAND),
}
# PX4's other spellings (nav_state names, the `commander mode` words, MAVSDK's FlightMode, QGroundControl's names).
_ALIASES: dict[str, FlightMode] = {
    **{mode.value: mode for mode in FlightMode},
    "ALTITUDE": FlightMode.ALTCTL,
    "POSITION": FlightMode.POSCTL,
    "POSITION:ORBIT": FlightMode.ORBIT,
    "POSCTL.ORBIT": FlightMode.ORBIT,
    "LOITER": FlightMode.HOLD,
    "AUTO.LOITER": FlightMode.HOLD,
    "AUTO:LOITER": FlightMode.HOLD,
    "AUTO.MISSION": FlightMode.MISSION,
    "AUTO:MISSION": FlightMode.MISSION,
    "RTL": FlightMode.RETURN,
    "RETURN_TO_LAUNCH": FlightMode.RETURN,
    "AUTO.RTL": FlightMode.RETURN,
    "AUTO:RTL": FlightMode.RETURN,
    "AUTO.TAKEOFF": FlightMode.TAKEOFF,
    "AUTO:TAKEOFF": FlightMode.TAKEOFF,
    "AUTO.LAND": FlightMode.LAND,
    "AUTO:LAND": FlightMode.LAND,
    "AUTO.PRECLAND": FlightMode.PRECLAND,
    "AUTO:PRECLAND": FlightMode.PRECLAND,
    "PRECISION_LAND": FlightMode.PRECLAND,
    "FOLLOWME": FlightMode.FOLLOW_ME,
    "AUTO.FOLLOW_TARGET": FlightMode.FOLLOW_ME,
}
