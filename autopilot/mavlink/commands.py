"""COMMAND_LONG / COMMAND_INT (and the SET_MODE message): checked, turned into typed requests for the flight
stack, and always answered with a COMMAND_ACK from our system and component 1 carrying the same command id.

Unknown commands get MAV_RESULT_UNSUPPORTED; refused ones DENIED or TEMPORARILY_REJECTED with a STATUSTEXT
saying why. A failure injection is acknowledged once the plant has answered (its outcome in the status).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from aircraft.failures import FailureRejected, parse_failure
from autopilot.region_of_interest import RegionOfInterest
from autopilot.commander import FORCE_MAGIC
from autopilot.home_position import home_at, home_here, home_refusal
from autopilot.mavlink import messages
from autopilot.mavlink.global_frames import altitude_amsl
from autopilot.mavlink.px4_modes import mode_from_px4, px4_mode_name
from autopilot.mavlink.router import COMP_ID, GroundLink
from autopilot.mavlink.statustext import Announcer
from autopilot.mavlink.streams import DEFAULT_RATES_HZ, MIN_INTERVAL_USEC, default_interval_usec
from autopilot.mavlink.view import StatusView
from autopilot.output_tests import MOTOR_COUNT, SERVO_COUNT
from autopilot.requests import (
    Arm,
    ChangeSpeed,
    Disarm,
    FlightTermination,
    InjectFailure,
    Land,
    Orbit,
    OutputTest,
    Reply,
    Reposition,
    RequestHandler,
    ReturnToLaunch,
    SetHome,
    SetMode,
    SetRegionOfInterest,
    StartMission,
    Takeoff,
    Transition,
    TurnTo,
)
from autopilot.vehicle_status import InjectionOutcome
from transport.geodesy import Home, ned_from_geodetic
from transport.mavlink import mavlink as M

Params = tuple[float, float, float, float, float, float, float]
MIN_TARGET_HEIGHT_M = 1.0  # a go-to or orbit target lower than this above home would fly into the ground
ORBIT_DEFAULT_RADIUS, ORBIT_MIN_RADIUS, ORBIT_MAX_RADIUS = 20.0, 1.0, 10000.0  # m (PX4: MC_ORBIT_RAD_MAX 1000)
ORBIT_DEFAULT_SPEED = 5.0  # m/s
ORBIT_YAW_DEFAULT = M.ORBIT_YAW_BEHAVIOUR_HOLD_FRONT_TO_CIRCLE_CENTER
ORBIT_YAW_BEHAVIOURS = range(M.ORBIT_YAW_BEHAVIOUR_UNCHANGED)  # 0..4: front to centre ... RC controlled
NO_STATE_YET = (M.MAV_RESULT_TEMPORARILY_REJECTED, "No vehicle state from the plant yet")


def int_param(value: float) -> int | None:
    """A command parameter that must be an integer: its value, or None if it is not one."""
    if not math.isfinite(value) or value != int(value):
        return None
    return int(value)


def for_us(system_id: int, target_system: int, target_component: int | None = None) -> bool:
    if target_system not in (0, system_id):
        return False
    return target_component is None or target_component in (0, COMP_ID)


@dataclass(frozen=True)
class Origin:
    """Who asked (for the COMMAND_ACK): the link, the sender's ids, the command."""

    link: GroundLink
    system: int
    component: int
    command: int


class CommandService:
    def __init__(self, flight_stack: RequestHandler, view: StatusView, announcer: Announcer, *, system_id: int,
                 home: Home) -> None:  # fmt: skip
        self.flight_stack = flight_stack
        self.view = view
        self.announcer = announcer
        self.system_id = system_id
        self.origin = home  # of the local frame (home, which arming and DO_SET_HOME move, is the status's)
        self._tickets: dict[int, Origin] = {}  # failure injections awaiting the plant's answer
        self._next_ticket = 1
        self._commands: dict[int, Callable[[Origin, Params, int | None], Reply | None]] = {
            M.MAV_CMD_COMPONENT_ARM_DISARM: self._arm,
            M.MAV_CMD_NAV_TAKEOFF: self._takeoff,
            M.MAV_CMD_NAV_LAND: lambda origin, p, frame: self.flight_stack.handle(Land()),
            M.MAV_CMD_DO_SET_MODE: self._set_mode_command,
            M.MAV_CMD_DO_VTOL_TRANSITION: self._transition,
            M.MAV_CMD_MISSION_START: lambda origin, p, frame: self.flight_stack.handle(StartMission()),
            M.MAV_CMD_NAV_RETURN_TO_LAUNCH: lambda origin, p, frame: self.flight_stack.handle(ReturnToLaunch()),
            M.MAV_CMD_DO_REPOSITION: self._reposition,
            M.MAV_CMD_DO_ORBIT: self._orbit,
            M.MAV_CMD_CONDITION_YAW: self._condition_yaw,
            M.MAV_CMD_DO_CHANGE_SPEED: self._change_speed,
            M.MAV_CMD_INJECT_FAILURE: self._inject_failure,
            M.MAV_CMD_REQUEST_MESSAGE: self._request_message,
            M.MAV_CMD_SET_MESSAGE_INTERVAL: self._set_interval,
            M.MAV_CMD_GET_MESSAGE_INTERVAL: self._get_interval,
            M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: self._capabilities,
            M.MAV_CMD_GET_HOME_POSITION: self._home,
            M.MAV_CMD_DO_SET_HOME: self._set_home,
            M.MAV_CMD_DO_SET_ROI_LOCATION: self._region_of_interest,
            M.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET: self._region_of_interest,
            M.MAV_CMD_DO_SET_ROI_NONE: self._region_of_interest,
            M.MAV_CMD_DO_SET_ROI: self._region_of_interest,
            M.MAV_CMD_DO_FLIGHTTERMINATION: self._flight_termination,
            M.MAV_CMD_DO_MOTOR_TEST: self._motor_test,
            M.MAV_CMD_ACTUATOR_TEST: self._actuator_test,
        }

    # ---- messages ---------------------------------------------------------------------------------------------
    def on_command_long(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            link.counters.ignored["command_for_other"] += 1
            return
        params = (message.param1, message.param2, message.param3, message.param4, message.param5, message.param6,
                  message.param7)  # fmt: skip
        self._command(link, message, params, frame=None)

    def on_command_int(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system, message.target_component):
            link.counters.ignored["command_for_other"] += 1
            return
        params = (message.param1, message.param2, message.param3, message.param4, float(message.x), float(message.y),
                  message.z)  # fmt: skip
        self._command(link, message, params, frame=message.frame)

    def on_set_mode(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message.target_system):
            return
        main, sub = (message.custom_mode >> 16) & 0xFF, (message.custom_mode >> 24) & 0xFF
        result, reason = self._set_mode(message.base_mode, main, sub)
        if reason:
            self.announcer.say(M.MAV_SEVERITY_WARNING, reason, key=f"set_mode:{reason}")

    def _command(self, link: GroundLink, message: Any, params: Params, frame: int | None) -> None:
        origin = Origin(link, message.get_srcSystem(), message.get_srcComponent(), message.command)
        handler = self._commands.get(message.command)
        if handler is None:
            self.ack(origin, M.MAV_RESULT_UNSUPPORTED)
            return
        reply = handler(origin, params, frame)
        if reply is not None:
            self.ack(origin, *reply)

    def ack(self, origin: Origin, result: int, reason: str | None = None) -> None:
        link = origin.link
        link.queue(link.mav.command_ack_encode(origin.command, result, 0, 0, origin.system, origin.component))
        if reason:
            severity = M.MAV_SEVERITY_WARNING if result != M.MAV_RESULT_ACCEPTED else M.MAV_SEVERITY_INFO
            self.announcer.say(severity, reason, key=f"ack:{origin.command}:{reason}")

    def injections_answered(self, outcomes: tuple[InjectionOutcome, ...]) -> None:
        """The plant answered forwarded injections (or did not, FAILED): acknowledge them and say so."""
        for outcome in outcomes:
            origin = self._tickets.pop(outcome.ticket, None)
            if origin is None:
                continue
            accepted = outcome.result == M.MAV_RESULT_ACCEPTED
            self.ack(origin, outcome.result)
            self.announcer.say(M.MAV_SEVERITY_WARNING if accepted else M.MAV_SEVERITY_ERROR, outcome.text)

    # ---- the commands -----------------------------------------------------------------------------------------
    def _arm(self, origin: Origin, p: Params, frame: int | None) -> Reply:
        force = p[1] == FORCE_MAGIC
        if p[0] == 1.0:
            return self.flight_stack.handle(Arm(force))
        if p[0] == 0.0:
            return self.flight_stack.handle(Disarm(force))
        return M.MAV_RESULT_DENIED, f"Arm/disarm: param1 must be 1 or 0, not {p[0]:g}"

    def _takeoff(self, origin: Origin, p: Params, frame: int | None) -> Reply | None:
        altitude, home = p[6], self.view.home
        if math.isnan(altitude):
            return self.flight_stack.handle(Takeoff(None))
        if not math.isfinite(altitude):
            return M.MAV_RESULT_DENIED, "Takeoff denied: param7 (altitude) is infinite"
        if home is None:
            return NO_STATE_YET
        amsl = altitude_amsl(frame, altitude, home.alt)
        if isinstance(amsl, str):
            return M.MAV_RESULT_DENIED, f"Takeoff denied: {amsl}"
        above_home = amsl - home.alt
        if not 1.0 <= above_home <= 1000.0:
            return M.MAV_RESULT_DENIED, (f"Takeoff denied: {altitude:g} m AMSL is {above_home:.0f} m above home "
                                         f"(1..1000 m; NaN: MIS_TAKEOFF_ALT)")  # fmt: skip
        return self.flight_stack.handle(Takeoff(above_home))

    def _set_mode_command(self, origin: Origin, p: Params, frame: int | None) -> Reply:
        base, main, sub = int_param(p[0]), int_param(p[1]), int_param(p[2]) if not math.isnan(p[2]) else 0
        if base is None or main is None or sub is None:
            return M.MAV_RESULT_DENIED, "Set mode: param1..3 must be integers (base mode, PX4 main, sub mode)"
        return self._set_mode(base, main, sub)

    def _set_mode(self, base: int, main: int, sub: int) -> Reply:
        if not base & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return M.MAV_RESULT_DENIED, "Set mode: only PX4 custom modes (base mode flag 1)"
        mode = mode_from_px4(main, sub)
        if mode is None:
            return M.MAV_RESULT_DENIED, (f"Mode {px4_mode_name(main, sub)} not supported: Hold Takeoff Land Offboard "
                                         "Mission Return Orbit Position Altitude")  # fmt: skip
        return self.flight_stack.handle(SetMode(mode))

    def _transition(self, origin: Origin, p: Params, frame: int | None) -> Reply:
        target = int_param(p[0])
        if target is None:
            return M.MAV_RESULT_DENIED, "Transition: param1 must be 3 (MC) or 4 (FW)"
        return self.flight_stack.handle(Transition(target))

    def _horizontal(self, p: Params, frame: int | None) -> tuple[float, float] | str:
        """params 5 and 6 (lat, lon; COMMAND_INT: degE7) as north and east, or why not."""
        lat, lon = (p[4] * 1e-7, p[5] * 1e-7) if frame is not None else (p[4], p[5])
        if not (math.isfinite(lat) and math.isfinite(lon)) or abs(lat) > 90.0 or abs(lon) > 180.0:
            return f"latitude/longitude {p[4]:g}, {p[5]:g} not valid"
        north, east, _ = ned_from_geodetic(self.origin, lat, lon, self.origin.alt)
        return north, east

    def _position(self, p: Params, frame: int | None) -> tuple[float, float, float | None] | str:
        """params 5-7 (lat, lon, alt; COMMAND_INT: degE7 and the frame's altitude) as north, east and down (None:
        NaN altitude), or why not; NaN lat/lon are refused here (the callers treat them first)."""
        horizontal = self._horizontal(p, frame)
        if isinstance(horizontal, str):
            return horizontal
        if math.isinf(p[6]):
            return "altitude infinite"
        north, east = horizontal
        down = self._down(p[6], frame)
        if isinstance(down, str):
            return down
        return north, east, down

    def _down(self, altitude: float, frame: int | None) -> float | None | str:
        """A command's altitude (in `frame`: global_frames.altitude_amsl) as NED down, checked to be at least
        MIN_TARGET_HEIGHT_M above home; None for NaN; why not, if not (call with a status)."""
        home = self.view.home
        if math.isnan(altitude) or home is None:
            return None
        amsl = altitude_amsl(frame, altitude, home.alt)
        if isinstance(amsl, str):
            return amsl
        down = self.origin.alt - amsl
        if home.down - down < MIN_TARGET_HEIGHT_M:
            return (f"altitude {home.down - down:.1f} m above home: targets stay at least {MIN_TARGET_HEIGHT_M:g} m "
                    "above it")  # fmt: skip
        return down

    def _reposition(self, origin: Origin, p: Params, frame: int | None) -> Reply | None:
        """MAV_CMD_DO_REPOSITION (MAVSDK goto_location): param1 speed (-1/NaN default), param4 yaw (rad, as PX4 and
        MAVSDK take it; NaN: the controllers' own rule), params 5-7 lat, lon, alt (NaN lat/lon: here; NaN alt: the
        current altitude)."""
        status = self.view.status
        if status is None:
            return NO_STATE_YET
        if math.isinf(p[3]):
            return M.MAV_RESULT_DENIED, "Reposition denied: param4 (yaw) infinite"
        here = status.estimate.position_ned
        target: tuple[float, float, float | None] | str
        if math.isnan(p[4]) or math.isnan(p[5]):
            down = self._down(p[6], frame)
            target = down if isinstance(down, str) else (float(here[0]), float(here[1]), down)
        else:
            target = self._position(p, frame)
        if isinstance(target, str):
            return M.MAV_RESULT_DENIED, f"Reposition denied: {target}"
        north, east, down = target
        speed = p[0] if math.isfinite(p[0]) and p[0] > 0 else None
        position = np.array([north, east, float(here[2]) if down is None else down])
        return self.flight_stack.handle(Reposition(position, speed, None if math.isnan(p[3]) else p[3]))

    def _region_of_interest(self, origin: Origin, p: Params, frame: int | None) -> Reply | None:
        """MAV_CMD_DO_SET_ROI_LOCATION (params 5, 6 lat, lon; the altitude is not used: the nose only turns),
        DO_SET_ROI_WPNEXT_OFFSET (param7 the yaw offset, deg), DO_SET_ROI_NONE, and the older DO_SET_ROI (param1
        MAV_ROI mode; LOCATION at params 5, 6)."""
        command = origin.command
        mode = {M.MAV_CMD_DO_SET_ROI_LOCATION: M.MAV_ROI_LOCATION, M.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET: M.MAV_ROI_WPNEXT,
                M.MAV_CMD_DO_SET_ROI_NONE: M.MAV_ROI_NONE}.get(command, int_param(p[0]))  # fmt: skip
        roi: RegionOfInterest | None = None
        if mode == M.MAV_ROI_LOCATION:
            point = self._horizontal(p, frame)
            if isinstance(point, str):
                return M.MAV_RESULT_DENIED, f"ROI denied: {point}"
            roi = RegionOfInterest(np.array(point))
        elif mode == M.MAV_ROI_WPNEXT:
            offset = p[6] if command == M.MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET else 0.0
            if not math.isfinite(offset):
                return M.MAV_RESULT_DENIED, "ROI denied: param7 (yaw offset) not finite"
            roi = RegionOfInterest(None, math.radians(offset))
        elif mode not in (M.MAV_ROI_NONE, M.MAV_ROI_WPINDEX):
            return M.MAV_RESULT_DENIED, f"ROI denied: param1 (ROI mode) {p[0]:g} not 0..3"
        return self.flight_stack.handle(SetRegionOfInterest(roi))

    def _flight_termination(self, origin: Origin, p: Params, frame: int | None) -> Reply | None:
        """MAV_CMD_DO_FLIGHTTERMINATION (MAVSDK's action.terminate()): param1 > 0.5 terminates (PX4's 1, and its 2,
        the lockdown test, likewise stop the motors here), otherwise clears a termination."""
        if not math.isfinite(p[0]):
            return M.MAV_RESULT_DENIED, "Flight termination denied: param1 not finite"
        return self.flight_stack.handle(FlightTermination(p[0] > 0.5))

    def _motor_test(self, origin: Origin, p: Params, frame: int | None) -> Reply | None:
        """MAV_CMD_DO_MOTOR_TEST: param1 motor 1 ... 4, param2 throttle type (only MOTOR_TEST_THROTTLE_PERCENT, as
        PX4), param3 throttle (%), param4 time-out (s, at most 3), param5 motor count (one at a time, as PX4)."""
        motor, kind = int_param(p[0]), int_param(p[1])
        count = int_param(p[4]) if math.isfinite(p[4]) else 0  # NaN: one
        if kind != M.MOTOR_TEST_THROTTLE_PERCENT or count is None or count > 1:
            return M.MAV_RESULT_UNSUPPORTED, "Motor test: only one motor at a time, throttle in percent"
        if motor is None or not 1 <= motor <= MOTOR_COUNT:
            return M.MAV_RESULT_DENIED, f"Motor test denied: param1 (motor) {p[0]:g} not 1..{MOTOR_COUNT}"
        if not math.isfinite(p[2]):
            return M.MAV_RESULT_DENIED, "Motor test denied: param3 (throttle) not finite"
        value = p[2] / 100.0
        return self.flight_stack.handle(OutputTest(True, motor - 1, value if value > 0.0 else None, p[3]))

    def _actuator_test(self, origin: Origin, p: Params, frame: int | None) -> Reply | None:
        """MAV_CMD_ACTUATOR_TEST (QGroundControl's Actuators page): param1 value (-1 ... 1), param2 time-out (s, at
        most 3; 0 or less releases the output), param5 ACTUATOR_OUTPUT_FUNCTION (MOTOR1 ... 4, SERVO1 ... 8)."""
        function = int_param(p[4])
        motor = function is not None and 0 <= function - M.ACTUATOR_OUTPUT_FUNCTION_MOTOR1 < MOTOR_COUNT
        servo = function is not None and 0 <= function - M.ACTUATOR_OUTPUT_FUNCTION_SERVO1 < SERVO_COUNT
        if function is None or not (motor or servo):
            return M.MAV_RESULT_UNSUPPORTED, (f"Actuator test: param5 (function) {p[4]:g} is no motor 1..{MOTOR_COUNT} "
                                              f"or servo 1..{SERVO_COUNT} output here")  # fmt: skip
        if math.isinf(p[0]) or not math.isfinite(p[1]):
            return M.MAV_RESULT_DENIED, "Actuator test denied: param1 (value) infinite or param2 (time-out) not finite"
        index = function - (M.ACTUATOR_OUTPUT_FUNCTION_MOTOR1 if motor else M.ACTUATOR_OUTPUT_FUNCTION_SERVO1)
        return self.flight_stack.handle(OutputTest(motor, index, p[0] if p[1] > 0.0 else None, p[1]))

    def _change_speed(self, origin: Origin, p: Params, frame: int | None) -> Reply | None:
        """MAV_CMD_DO_CHANGE_SPEED: param2 the speed (> 0; -1, -2 or 0: back to the defaults, as PX4's navigator);
        param1 (airspeed or ground speed) is not told apart, as PX4 does not."""
        if math.isnan(p[1]) or math.isinf(p[1]):
            return M.MAV_RESULT_DENIED, "Change speed denied: param2 (speed) not finite"
        return self.flight_stack.handle(ChangeSpeed(p[1] if p[1] > 0 else None))

    def _orbit(self, origin: Origin, p: Params, frame: int | None) -> Reply | None:
        """MAV_CMD_DO_ORBIT: param1 radius (sign: direction, positive clockwise), param2 velocity (NaN: default),
        param3 ORBIT_YAW_BEHAVIOUR (NaN or UNCHANGED: HOLD_FRONT_TO_CIRCLE_CENTER, PX4's default), params 5-7 centre
        (NaN: here)."""
        behaviour = ORBIT_YAW_DEFAULT if math.isnan(p[2]) or p[2] == M.ORBIT_YAW_BEHAVIOUR_UNCHANGED else int_param(p[2])
        if behaviour is None or behaviour not in ORBIT_YAW_BEHAVIOURS:
            return M.MAV_RESULT_DENIED, f"Orbit denied: param3 (yaw behaviour) {p[2]:g} not 0..5"
        radius = p[0] if math.isfinite(p[0]) and p[0] != 0 else ORBIT_DEFAULT_RADIUS
        if not ORBIT_MIN_RADIUS <= abs(radius) <= ORBIT_MAX_RADIUS:
            return M.MAV_RESULT_DENIED, (f"Orbit denied: radius {abs(radius):g} m not in "
                                         f"{ORBIT_MIN_RADIUS:g}..{ORBIT_MAX_RADIUS:g} m")  # fmt: skip
        speed = abs(p[1]) if math.isfinite(p[1]) and p[1] != 0 else ORBIT_DEFAULT_SPEED
        if self.view.status is None:
            return NO_STATE_YET
        if math.isnan(p[4]) or math.isnan(p[5]):
            center, down = None, self._down(p[6], frame)
            if isinstance(down, str):
                return M.MAV_RESULT_DENIED, f"Orbit denied: {down}"
        else:
            target = self._position(p, frame)
            if isinstance(target, str):
                return M.MAV_RESULT_DENIED, f"Orbit denied: {target}"
            center, down = np.array(target[0:2]), target[2]
        return self.flight_stack.handle(Orbit(center, down, abs(radius), radius > 0, speed, behaviour))

    def _condition_yaw(self, origin: Origin, p: Params, frame: int | None) -> Reply | None:
        """MAV_CMD_CONDITION_YAW: param1 angle (deg), param3 direction for a relative turn (-1 counter-clockwise, 1 or
        0 clockwise), param4 0 absolute / 1 relative; param2 (rate) is not taken: the turn is at MPC_YAWRAUTO_MAX."""
        relative = int_param(p[3])
        if not math.isfinite(p[0]) or relative not in (0, 1) or int_param(p[2]) not in (-1, 0, 1):
            return M.MAV_RESULT_DENIED, "Condition yaw denied: param1 finite, param3 -1/0/1, param4 0 or 1"
        return self.flight_stack.handle(TurnTo(math.radians(p[0]), relative == 1, p[2] >= 0))

    def _inject_failure(self, origin: Origin, p: Params, frame: int | None) -> Reply | None:
        try:
            failure = parse_failure(p[0], p[1], p[2], p[3])
        except FailureRejected as refusal:
            result = M.MAV_RESULT_UNSUPPORTED if refusal.unsupported else M.MAV_RESULT_DENIED
            return result, f"Failure injection: {refusal}"
        ticket = self._next_ticket
        self._next_ticket += 1
        reply = self.flight_stack.handle(InjectFailure(failure, ticket))
        if reply is None:
            self._tickets[ticket] = origin  # acknowledged when the plant has answered
        return reply

    def _request_message(self, origin: Origin, p: Params, frame: int | None) -> Reply | None:
        status = self.view.status
        if status is None:
            return NO_STATE_YET
        msgid = int_param(p[0])
        message = messages.build(msgid, origin.link.mav, status) if msgid is not None else None
        if message is None:
            return M.MAV_RESULT_DENIED, f"Message {p[0]:g} not available on request"
        self.ack(origin, M.MAV_RESULT_ACCEPTED)
        origin.link.queue(message)
        return None

    def _capabilities(self, origin: Origin, p: Params, frame: int | None) -> Reply:
        origin.link.queue(messages.autopilot_version(origin.link.mav))
        return M.MAV_RESULT_ACCEPTED, None

    def _home(self, origin: Origin, p: Params, frame: int | None) -> Reply:
        if self.view.home is None:
            return NO_STATE_YET
        origin.link.queue(messages.home_position(origin.link.mav, self.view.home, self.view.now_usec))
        return M.MAV_RESULT_ACCEPTED, None

    def _set_home(self, origin: Origin, p: Params, frame: int | None) -> Reply | None:
        """MAV_CMD_DO_SET_HOME, as PX4's commander: param1 > 0.5 where the vehicle is, else params 5-7 (latitude,
        longitude, altitude AMSL; in the RELATIVE_ALT frames above the current home). Non-finite coordinates are
        DENIED (PX4), and so are ones out of range."""
        status = self.view.status
        if status is None:
            return NO_STATE_YET
        if p[0] > 0.5:
            return self.flight_stack.handle(SetHome(home_here(self.origin, status.estimate.position_ned), True))
        lat, lon = (p[4] * 1e-7, p[5] * 1e-7) if frame is not None else (p[4], p[5])
        alt = altitude_amsl(frame, p[6], status.home.alt)
        if isinstance(alt, str):
            return M.MAV_RESULT_DENIED, f"Set home denied: {alt}"
        if (why := home_refusal(lat, lon, alt)) is not None:
            return M.MAV_RESULT_DENIED, f"Set home denied: {why}"
        return self.flight_stack.handle(SetHome(home_at(self.origin, lat, lon, alt), False))

    def _set_interval(self, origin: Origin, p: Params, frame: int | None) -> Reply:
        msgid = int_param(p[0])
        interval = p[1]
        if msgid is None or msgid not in DEFAULT_RATES_HZ:
            return M.MAV_RESULT_DENIED, f"Message interval: message {p[0]:g} is not a stream here"
        if not math.isfinite(interval) or (interval < 0 and interval != -1):
            return M.MAV_RESULT_DENIED, f"Message interval: {interval:g} us (-1 off, 0 default, >0 us)"
        if interval == 0:
            usec = default_interval_usec(msgid)
        elif interval == -1:
            usec = 0
        else:
            usec = max(int(interval), MIN_INTERVAL_USEC)
        origin.link.streams.set_interval(msgid, usec, self.view.now_usec)
        return M.MAV_RESULT_ACCEPTED, None

    def _get_interval(self, origin: Origin, p: Params, frame: int | None) -> Reply | None:
        msgid = int_param(p[0])
        if msgid is None or not 0 <= msgid < (1 << 24):
            return M.MAV_RESULT_DENIED, "Get message interval: param1 must be a message id"
        link = origin.link
        interval = link.streams.intervals.get(msgid, 0 if msgid in DEFAULT_RATES_HZ else -1)
        self.ack(origin, M.MAV_RESULT_ACCEPTED)
        link.queue(link.mav.message_interval_encode(msgid, interval if interval else -1))
        return None
