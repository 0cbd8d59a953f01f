"""Guided requests: the commands that steer the vehicle beside arming and the mode choice (Land, Go-to, Orbit, VTOL
transition, cruise speed, home, Offboard set-points, a turn in Hold), judged against the commander's state as PX4's
commander does."""

from __future__ import annotations

from aircraft.frames import wrap
from autopilot.commander.commander import ACCEPTED, DENIED, TEMPORARILY_REJECTED, Commander
from autopilot.navigator.auto_flight import Circle
from autopilot.navigator.modes.hold import HOLD, VTOL_FW, VTOL_MC
from autopilot.navigator.modes.land import LAND
from autopilot.navigator.modes.offboard import OFFBOARD
from autopilot.navigator.modes.orbit import ORBIT
from autopilot.navigator.offboard_setpoint import SETPOINT_LIMITS
from autopilot.topics.region_of_interest import RegionOfInterest
from autopilot.topics.requests import (
    OffboardAttitude,
    OffboardPosition,
    OffboardVelocity,
    Orbit,
    Reply,
    Reposition,
    SetHome,
    TurnTo,
)
from autopilot.topics.vehicle_state import VehicleState
from transport.mavlink import mavlink

MAX_CRUISE_SPEED = float(SETPOINT_LIMITS[0])  # m/s: DO_CHANGE_SPEED within the velocity envelope


class GuidedRequests:
    """Judges a guided request against the commander's state and hands it to the commander."""

    def __init__(self, commander: Commander) -> None:
        self.commander = commander

    def land(self, state: VehicleState) -> Reply:
        c = self.commander
        if (refusal := c.refusal("Land")) is not None:
            return refusal
        c.switch_mode(LAND, state, "Landing")
        return ACCEPTED, None

    def set_home(self, request: SetHome) -> Reply:
        """MAV_CMD_DO_SET_HOME: Return and the geofence's distances use the new home from now (PX4: refused,
        TEMPORARILY_REJECTED, without a position estimate)."""
        c = self.commander
        if (refusal := c.refusal("Set home", positional=request.current)) is not None:
            return refusal
        home = request.home
        c.set_home(home)
        c.say(mavlink.MAV_SEVERITY_INFO, f"Home position: {home.lat:.7f}, {home.lon:.7f}, {home.alt:.2f}")
        return ACCEPTED, None

    def transition(self, target: int, state: VehicleState) -> Reply:
        """MAV_CMD_DO_VTOL_TRANSITION: in Hold, to FW circles at cruise speed, to MC brakes and hovers."""
        c = self.commander
        if (refusal := c.refusal()) is not None:
            return refusal
        if target not in (VTOL_FW, VTOL_MC):
            return DENIED, f"Transition denied: param1 must be {VTOL_MC} (MC) or {VTOL_FW} (FW)"
        if not c.flying:
            return TEMPORARILY_REJECTED, "Transition denied: not flying"
        if c.mode == OFFBOARD:
            return TEMPORARILY_REJECTED, "Transition denied: in Offboard the set-points choose the phase"
        if c.mode != HOLD:
            return TEMPORARILY_REJECTED, f"Transition denied: in {c.mode} (switch to Hold first)"
        if (text := c.transition(target, state)) is not None:
            c.say(mavlink.MAV_SEVERITY_INFO, text)
        return ACCEPTED, None

    def offboard_request(self, request: OffboardVelocity | OffboardPosition | OffboardAttitude) -> Reply:
        """A client's Offboard set-point, judged against the current step's state (Commander.observe())."""
        c = self.commander
        if isinstance(request, OffboardAttitude):
            if c.offboard.accept(request, c.state, c.now_usec):
                c.say(mavlink.MAV_SEVERITY_WARNING, "Attitude set-point clamped (tilt <= 45 deg, rates <= 180 "
                      "deg/s, thrust 0..1)", key="attitude clamped")  # fmt: skip
            return ACCEPTED, None
        if c.offboard.accept(request, c.state, c.now_usec):
            c.say(mavlink.MAV_SEVERITY_WARNING, "Set-point clamped to |v| <= (30, 30, 10) m/s, |yaw rate| <= 180 "
                  "deg/s", key="clamped")  # fmt: skip
        return ACCEPTED, None

    def route(self, request: Reposition | Orbit, state: VehicleState) -> Reply:
        """DO_REPOSITION: Hold at a new position (flown there); DO_ORBIT: Orbit mode around a centre."""
        c = self.commander
        name = "Reposition" if isinstance(request, Reposition) else "Orbit"
        if (refusal := c.refusal(name, positional=True)) is not None:
            return refusal
        if not c.flying:
            return TEMPORARILY_REJECTED, f"{name} denied: not flying"
        if isinstance(request, Reposition):
            c.switch_mode(HOLD, state, "Reposition: Hold")
            c.reposition(state, request.position, request.speed, request.yaw)
            return ACCEPTED, None
        center = state.position_ned[0:2].copy() if request.center is None else request.center
        down = float(state.position_ned[2]) if request.down is None else request.down
        c.switch_mode(ORBIT, state, f"Orbit: radius {request.radius:g} m at {request.speed:g} m/s")
        c.orbit(state, Circle(center, down, request.radius, request.speed, request.clockwise,
                                    request.yaw_behaviour, float(state.euler[2])))  # fmt: skip
        return ACCEPTED, None

    def point_at(self, roi: RegionOfInterest | None) -> Reply:
        """DO_SET_ROI_*: the vehicle's region of interest, which Mission flies by (at once if it is flying; PX4's
        navigator keeps it in any mode and acknowledges it ACCEPTED)."""
        c = self.commander
        if (refusal := c.refusal()) is not None:
            return refusal
        c.set_region_of_interest(roi)
        return ACCEPTED, None

    def turn_to(self, request: TurnTo, state: VehicleState) -> Reply:
        """MAV_CMD_CONDITION_YAW: in Hold, hold here turned to the heading (PX4 takes it in missions only; ArduPilot
        in its Guided mode, which Hold stands for here)."""
        c = self.commander
        if (refusal := c.refusal("Condition yaw", positional=True)) is not None:
            return refusal
        if not c.flying or c.mode != HOLD:
            return TEMPORARILY_REJECTED, f"Condition yaw denied: in {c.mode if c.flying else 'no flight'} (Hold only)"
        heading = request.angle
        if request.relative:
            heading = float(state.euler[2]) + (heading if request.clockwise else -heading)
        c.reposition(state, state.position_ned.copy(), None, wrap(heading))
        return ACCEPTED, None

    def change_speed(self, speed: float | None) -> Reply:
        """DO_CHANGE_SPEED: the cruise speed of the legs of Mission, Return and Go-to (None: the defaults), within
        the velocity controllers' envelope."""
        c = self.commander
        if (refusal := c.refusal()) is not None:
            return refusal
        if speed is not None and speed > MAX_CRUISE_SPEED:
            c.say(mavlink.MAV_SEVERITY_WARNING, f"Speed {speed:g} m/s clamped to {MAX_CRUISE_SPEED:g} m/s")
            speed = MAX_CRUISE_SPEED
        c.set_cruise_speed(speed)
        c.say(mavlink.MAV_SEVERITY_INFO, "Speed: defaults" if speed is None else f"Speed: {speed:g} m/s")
        return ACCEPTED, None
