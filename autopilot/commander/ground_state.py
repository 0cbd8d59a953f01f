"""On the ground or in the air, as PX4's commander and land detector keep it: lift-offs (each one a fresh
flight controller), touchdowns, and the two automatic disarms on the ground (COM_DISARM_LAND after a landing,
COM_DISARM_PRFLT when an armed vehicle does not take off), and the MAV_LANDED_STATE it makes. Times are simulation
microseconds."""

from __future__ import annotations

from autopilot.storage.parameters import ParameterStore
from transport.mavlink import mavlink


def landed_state(started: bool, on_ground: bool, taking_off: bool, landing: bool) -> int:
    """MAV_LANDED_STATE, as EXTENDED_SYS_STATE reports it."""
    if not started:
        return mavlink.MAV_LANDED_STATE_UNDEFINED
    if on_ground:
        return mavlink.MAV_LANDED_STATE_ON_GROUND
    if taking_off:
        return mavlink.MAV_LANDED_STATE_TAKEOFF
    if landing:
        return mavlink.MAV_LANDED_STATE_LANDING
    return mavlink.MAV_LANDED_STATE_IN_AIR


class GroundState:
    def __init__(self, in_air: bool) -> None:
        self.on_ground = not in_air
        self.flight_number = 0  # lift-offs so far: each starts a fresh flight controller
        self._controller_flight = 0  # the flight the running flight controller was started for
        self._armed_usec: int | None = None  # armed on the ground since
        self._landed_usec: int | None = None  # touched down at

    @property
    def controller_reset(self) -> bool:
        """A takeoff began that no fresh flight controller has been started for yet."""
        return self.flight_number != self._controller_flight

    def controller_started(self) -> None:
        self._controller_flight = self.flight_number

    def armed(self, time_usec: int) -> None:
        """Armed (or restarted armed) at `time_usec`: the pre-flight disarm timer runs from here."""
        self._armed_usec = time_usec

    def disarmed(self) -> None:
        self.on_ground = True  # unpowered, the vehicle ends on the ground
        self._landed_usec = None

    def restarted(self, time_usec: int, armed: bool) -> None:
        """The plant's clock went back: the timers start afresh."""
        self._landed_usec = None
        if armed:
            self._armed_usec = time_usec

    def lift_off(self) -> None:
        self.on_ground = False
        self.flight_number += 1
        self._armed_usec = None
        self._landed_usec = None

    def touch_down(self, time_usec: int) -> None:
        self.on_ground = True
        self._landed_usec = time_usec

    def disarm_due(self, params: ParameterStore, time_usec: int) -> str | None:
        """Why the vehicle, armed on the ground, disarms now (None: it stays armed)."""
        if self._landed_usec is not None and time_usec - self._landed_usec >= params["COM_DISARM_LAND"] * 1e6:
            return "Disarmed after landing"
        preflight = params["COM_DISARM_PRFLT"]
        if self._landed_usec is None and self._armed_usec is not None and preflight >= 0 \
                and time_usec - self._armed_usec >= preflight * 1e6:  # fmt: skip
            return f"Disarmed: no takeoff within {preflight:g} s"
        return None
