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
from autopilot.mavlink import messages
from autopilot.mavlink.command_params import GlobalTargets, Params, int_param, latitude_longitude
from autopilot.mavlink.global_frames import altitude_amsl
from autopilot.mavlink.output_commands import actuator_test, flight_termination, motor_test
from autopilot.mavlink.router import COMP_ID, GroundLink
from autopilot.mavlink.statustext import Announcer
from autopilot.mavlink.streams import DEFAULT_RATES_HZ, MIN_INTERVAL_USEC, default_interval_usec
from autopilot.mavlink.view import StatusView
from autopilot.topics.flight_mode import ModeId, px4_mode_name
from autopilot.topics.home_position import home_at, home_here, home_refusal
from autopilot.topics.region_of_interest import RegionOfInterest, roi_mode, wpnext_offset_deg
from autopilot.topics.requests import (
    FORCE_MAGIC,
    Arm,
    ChangeSpeed,
    Disarm,
    InjectFailure,
    Land,
    Orbit,
    Reply,
    Reposition,
    Request,
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
from autopilot.topics.vehicle_status import InjectionOutcome
from transport.geodesy import Home
from transport.mavlink import mavlink as M

ORBIT_DEFAULT_RADIUS, ORBIT_MIN_RADIUS, ORBIT_MAX_RADIUS = 20.0, 1.0, 10000.0  # m (PX4: MC_ORBIT_RAD_MAX 1000)
ORBIT_DEFAULT_SPEED = 5.0  # m/s
ORBIT_YAW_DEFAULT = M.ORBIT_YAW_BEHAVIOUR_HOLD_FRONT_TO_CIRCLE_CENTER
ORBIT_YAW_BEHAVIOURS = range(M.ORBIT_YAW_BEHAVIOUR_UNCHANGED)  # 0..4: front to centre ... RC controlled
NO_STATE_YET = (M.MAV_RESULT_TEMPORARILY_REJECTED, "No vehicle state from the plant yet")


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
                 home: Home, modes: tuple[ModeId, ...]) -> None:  # fmt: skip
        """modes: the vehicle's modes, which SET_MODE and MAV_CMD_DO_SET_MODE may choose."""
        self.flight_stack = flight_stack
        self.modes = modes
        self.view = view
        self.announcer = announcer
        self.system_id = system_id
        self.origin = home  # of the local frame (home, which arming and DO_SET_HOME move, is the status's)
        self.targets = GlobalTargets(home, view)  # command positions as NED targets
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
            M.MAV_CMD_DO_FLIGHTTERMINATION: lambda origin, p, frame: self._parsed(flight_termination(p)),
            M.MAV_CMD_DO_MOTOR_TEST: lambda origin, p, frame: self._parsed(motor_test(p)),
            M.MAV_CMD_ACTUATOR_TEST: lambda origin, p, frame: self._parsed(actuator_test(p)),
        }

    @property
    def handled_commands(self) -> tuple[int, ...]:
        """The MAV_CMD ids this service carries out (its dispatch table)."""
        return tuple(self._commands)

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
    def _parsed(self, parsed: Request | Reply) -> Reply | None:
        """A request read from a command's parameters, handed to the flight stack; or the reply refusing them."""
        return parsed if isinstance(parsed, tuple) else self.flight_stack.handle(parsed)

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
        mode = next((mode for mode in self.modes if mode.matches(main, sub)), None)
        if mode is None:
            return M.MAV_RESULT_DENIED, (f"Mode {px4_mode_name(main, sub)} not supported: "
                                         f"{' '.join(mode.name for mode in self.modes)}")  # fmt: skip
        return self.flight_stack.handle(SetMode(mode.name))

    def _transition(self, origin: Origin, p: Params, frame: int | None) -> Reply:
        target = int_param(p[0])
        if target is None:
            return M.MAV_RESULT_DENIED, "Transition: param1 must be 3 (MC) or 4 (FW)"
        return self.flight_stack.handle(Transition(target))

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
            down = self.targets.down(p[6], frame)
            target = down if isinstance(down, str) else (float(here[0]), float(here[1]), down)
        else:
            target = self.targets.position(p, frame)
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
        mode = roi_mode(origin.command, p[0])
        roi: RegionOfInterest | None = None
        if mode == M.MAV_ROI_LOCATION:
            point = self.targets.horizontal(p, frame)
            if isinstance(point, str):
                return M.MAV_RESULT_DENIED, f"ROI denied: {point}"
            roi = RegionOfInterest(np.array(point))
        elif mode == M.MAV_ROI_WPNEXT:
            offset = wpnext_offset_deg(origin.command, p[6])
            if not math.isfinite(offset):
                return M.MAV_RESULT_DENIED, "ROI denied: param7 (yaw offset) not finite"
            roi = RegionOfInterest(None, math.radians(offset))
        elif mode not in (M.MAV_ROI_NONE, M.MAV_ROI_WPINDEX):
            return M.MAV_RESULT_DENIED, f"ROI denied: param1 (ROI mode) {p[0]:g} not 0..3"
        return self.flight_stack.handle(SetRegionOfInterest(roi))

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
        behaviour = (
            ORBIT_YAW_DEFAULT if math.isnan(p[2]) or p[2] == M.ORBIT_YAW_BEHAVIOUR_UNCHANGED else int_param(p[2])
        )
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
            center, down = None, self.targets.down(p[6], frame)
            if isinstance(down, str):
                return M.MAV_RESULT_DENIED, f"Orbit denied: {down}"
        else:
            target = self.targets.position(p, frame)
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
        lat, lon = latitude_longitude(p, frame)
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
