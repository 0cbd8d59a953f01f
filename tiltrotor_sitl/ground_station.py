"""A ground station for tests, on pymavlink: connected to the vehicle's GCS link, saying the ground station's
HEARTBEAT each second on its own, and doing what a test otherwise writes again each time, as PX4's and MAVSDK's
ground stations do it.

    gcs = vehicle.ground_station            # connected; a thread reads the link and says HEARTBEAT
    gcs.arm()
    gcs.set_mode("OFFBOARD")                # PX4's mode names (tiltrotor_sitl.FlightMode)
    gcs.takeoff(8.0)                        # metres above home
    gcs.command(mavlink.MAV_CMD_DO_CHANGE_SPEED, 1, 5.0)  # any COMMAND_LONG: its COMMAND_ACK
    gcs.send(gcs.mav.set_position_target_local_ned_encode(...))  # any message (the raw pymavlink connection:
                                                                 # gcs.connection)

Commands are addressed to the vehicle's system id (never a default of 1) and its autopilot (component 1). A command
not acknowledged within ACK_TIMEOUT_S is sent again, its confirmation counting the resends, at most
COMMAND_RETRIES times (PX4's and MAVSDK's command senders); MAV_RESULT_IN_PROGRESS waits IN_PROGRESS_TIMEOUT_S
more for the final answer (MAVSDK). The ACK that answers is the first COMMAND_ACK for that command from that system
and component after the first send. Time-outs are wall seconds, as in MAVSDK.

A `GroundLink` is one pymavlink connection and its thread; every vehicle sending to it (a fleet shares one GCS port)
has its own `GroundStation` on it, hearing only that vehicle. The link writes a .tlog (every message received and
sent, with its time, as QGroundControl and MAVProxy write them; `mavlogdump.py` reads it).
"""

from __future__ import annotations

import math
import struct
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from pymavlink import mavutil

from aircraft.failures import FailureRejected, FailureType, FailureUnit, parse_failure
from autopilot.topics.mission_items import MISSION, TYPE_NAMES, MissionItem
from tiltrotor_sitl.flight_modes import FlightMode
from transport.mavlink import mavlink as M
from transport.ports import LOOPBACK

ACK_TIMEOUT_S = 0.5  # PX4's and MAVSDK's: a command unanswered this long is sent again
COMMAND_RETRIES = 3  # PX4's and MAVSDK's: resends before giving up
IN_PROGRESS_TIMEOUT_S = 3.0  # MAVSDK's: after MAV_RESULT_IN_PROGRESS, the wait for the final ACK
HEARTBEAT_PERIOD_S = 1.0  # a ground station's HEARTBEAT (PX4's data-link loss counts them)
PARAMETER_TIMEOUT_S = 1.0  # a PARAM_SET or PARAM_REQUEST_READ unanswered this long is sent again
PARAMETER_RETRIES = 3
MISSION_TIMEOUT_S = 1.5  # a MISSION_COUNT unanswered this long is sent again
MISSION_RETRIES = 5
MISSION_UPLOAD_TIMEOUT_S = 60.0
REASON_WAIT_S = 0.3  # after a refusal, how long its STATUSTEXT is waited for (a refusal may come without one)
MESSAGES_KEPT = 20_000  # per vehicle: the window the waits look back on (minutes of telemetry)
GCS_SYSTEM_ID = 255
GCS_COMPONENT_ID = M.MAV_COMP_ID_MISSIONPLANNER
AUTOPILOT_COMPONENT = 1
FORCE_DISARM = 21196.0  # MAV_CMD_COMPONENT_ARM_DISARM param2: disarm even in flight
STATUSTEXT_CHUNK = 50  # bytes; a longer text comes in chunks sharing an id, the last one shorter
RESULT_NAMES = {value: entry.name for value, entry in M.enums["MAV_RESULT"].items()}
STATE_NAMES = {value: entry.name.removeprefix("MAV_STATE_") for value, entry in M.enums["MAV_STATE"].items()}
LANDED_NAMES = {value: entry.name.removeprefix("MAV_LANDED_STATE_").lower().replace("_", " ")
                for value, entry in M.enums["MAV_LANDED_STATE"].items()}  # fmt: skip


class CommandError(RuntimeError):
    """A command was not carried out: refused by the vehicle, or never acknowledged."""


class CommandRefused(CommandError):
    """The vehicle answered a command with a result other than MAV_RESULT_ACCEPTED (`result`); the message says the
    vehicle's last STATUSTEXT, which says why."""

    def __init__(self, message: str, result: int) -> None:
        super().__init__(message)
        self.result = result


class CommandTimeout(CommandError):
    """No answer after the resends."""


# ---- values on the wire ----------------------------------------------------------------------------------------
def encode_parameter(value: float, param_type: int) -> float:
    """The float that carries `value` in PARAM_SET.param_value: integers bytewise in the float (PX4's encoding,
    MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE), REAL32 as it is."""
    if param_type == M.MAV_PARAM_TYPE_REAL32:
        return float(value)
    return struct.unpack("<f", struct.pack("<i", int(value)))[0]


def decode_parameter(param_value: float, param_type: int) -> float:
    """The value a PARAM_VALUE carries (the inverse of encode_parameter)."""
    if param_type == M.MAV_PARAM_TYPE_REAL32:
        return param_value
    return float(struct.unpack("<i", struct.pack("<f", param_value))[0])


def failure_params(unit: str, failure_type: str, instance: int, value: float) -> tuple[float, float, float, float]:
    """MAV_CMD_INJECT_FAILURE's param1..4 for PX4's names (its `failure` command: "motor", "servo", "gps" ...;
    "off", "stuck", "wrong", "ok"); ValueError naming what this vehicle simulates otherwise."""
    units = {member.name.lower(): member for member in FailureUnit}
    types = {member.name.lower(): member for member in FailureType}
    if unit.lower() not in units:
        raise ValueError(f"failure unit {unit!r}: one of {', '.join(units)}")
    if failure_type.lower() not in types:
        raise ValueError(f"failure type {failure_type!r}: one of {', '.join(types)}")
    params = (float(units[unit.lower()]), float(types[failure_type.lower()]), float(instance), float(value))
    try:
        parse_failure(*params)
    except FailureRejected as refusal:
        raise ValueError(str(refusal)) from None
    return params


# ---- what one vehicle has said -------------------------------------------------------------------------------
class _Inbox:
    """The messages of one system as they arrive: numbered from 1, at least the last MESSAGES_KEPT of them, the
    latest of each type, and its STATUSTEXTs whole (chunks joined)."""

    def __init__(self) -> None:
        self.changed = threading.Condition()
        self.window: list[Any] = []  # the messages numbered first .. received
        self.first = 1
        self.received = 0  # messages numbered so far
        self.latest: dict[str, Any] = {}
        self.statustexts: list[str] = []
        self._chunks: dict[int, dict[int, str]] = {}

    def put(self, message: Any) -> None:
        with self.changed:
            self.received += 1
            self.window.append(message)
            if len(self.window) > 2 * MESSAGES_KEPT:
                del self.window[:MESSAGES_KEPT]
                self.first += MESSAGES_KEPT
            kind = message.get_type()
            if kind == "HEARTBEAT" and message.get_srcComponent() != AUTOPILOT_COMPONENT:
                kind = f"HEARTBEAT/{message.get_srcComponent()}"  # another component's: not the vehicle's state
            self.latest[kind] = message
            if kind == "STATUSTEXT":
                self._statustext(message)
            self.changed.notify_all()

    def _statustext(self, message: Any) -> None:
        if message.id == 0:
            self.statustexts.append(message.text)
            return
        parts = self._chunks.setdefault(message.id, {})
        parts[message.chunk_seq] = message.text
        if len(message.text.encode()) < STATUSTEXT_CHUNK:
            self.statustexts.append("".join(parts[i] for i in sorted(parts)))
            del self._chunks[message.id]

    def wait_statustexts(self, count: int, timeout_s: float) -> list[str]:
        """The whole STATUSTEXTs after the first `count`, once there is one (or `timeout_s` has passed)."""
        with self.changed:
            self.changed.wait_for(lambda: len(self.statustexts) > count, timeout_s)
            return self.statustexts[count:]

    def wait(self, after: int, accept: Callable[[Any], bool], timeout_s: float) -> tuple[int, Any] | None:
        """The first message numbered after `after` that `accept` takes (its number and itself), waited for up to
        `timeout_s`; None."""
        deadline = time.monotonic() + timeout_s
        seen = after
        with self.changed:
            while True:
                start = max(seen + 1, self.first)
                for number, message in enumerate(self.window[start - self.first :], start):
                    if accept(message):
                        return number, message
                seen = self.received
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                self.changed.wait(left)


# ---- the connection ------------------------------------------------------------------------------------------
class GroundLink:
    """One pymavlink connection (`url`, e.g. "udpin:127.0.0.1:14550"), read by a thread that hands each message to
    the GroundStation of its system and says the ground station's HEARTBEAT every HEARTBEAT_PERIOD_S (once it knows
    where to: a udpin link after the first datagram). A .tlog of it all at `tlog` (None: none)."""

    def __init__(self, url: str, tlog: Path | None = None) -> None:
        self.url = url
        self.tlog = tlog
        self.connection: Any = mavutil.mavlink_connection(url, source_system=GCS_SYSTEM_ID,
                                                          source_component=GCS_COMPONENT_ID, dialect="common")  # fmt: skip
        self._send_lock = threading.Lock()
        self._inboxes: dict[int, _Inbox] = {}
        self._inboxes_lock = threading.Lock()
        self._log: IO[bytes] | None = None
        if tlog is not None:
            self._log = open(tlog, "ab")  # noqa: SIM115 (closed in close(), after the reader has stopped)
            self.connection.mav.set_send_callback(self._logged)
        self._stop = threading.Event()
        self._reader = threading.Thread(target=self._read, name=f"ground-link:{url}", daemon=True)
        self._reader.start()

    @classmethod
    def listening(cls, port: int, tlog: Path | None = None) -> GroundLink:
        """On 127.0.0.1:`port`, where vehicles' GCS links send (as QGroundControl listens on 14550)."""
        return cls(f"udpin:{LOOPBACK}:{port}", tlog)

    @classmethod
    def speaking_to(cls, port: int, tlog: Path | None = None, address: str = LOOPBACK) -> GroundLink:
        """Sending first to a vehicle's own GCS port, `address`:`port` (it answers the address it heard from)."""
        return cls(f"udpout:{address}:{port}", tlog)

    def station(self, target_system: int) -> GroundStation:
        """A GroundStation for the vehicle of system id `target_system` on this link."""
        return GroundStation(self, target_system)

    def inbox(self, system_id: int) -> _Inbox:
        with self._inboxes_lock:
            return self._inboxes.setdefault(system_id, _Inbox())

    def send(self, message: Any) -> None:
        """Send one message (pymavlink's encoded message, e.g. link.connection.mav.heartbeat_encode(...))."""
        with self._send_lock:
            self.connection.mav.send(message)

    def close(self) -> None:
        self._stop.set()
        self._reader.join(timeout=5.0)
        self.connection.close()
        if self._log is not None:
            self._log.close()

    def _logged(self, message: Any) -> None:
        """Into the .tlog: the time (us since the epoch, big-endian, as QGroundControl writes it) and the frame."""
        if self._log is not None and not self._log.closed:
            self._log.write(struct.pack(">Q", int(time.time() * 1e6) & ~3) + message.get_msgbuf())

    def _read(self) -> None:
        heartbeat_at = 0.0
        while not self._stop.is_set():
            if time.monotonic() - heartbeat_at >= HEARTBEAT_PERIOD_S:
                heartbeat_at = time.monotonic()
                self.send(self.connection.mav.heartbeat_encode(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0,
                                                               M.MAV_STATE_ACTIVE))  # fmt: skip
                if self._log is not None:
                    self._log.flush()  # a test that fails finds the log written up to the last second
            message = self.connection.recv_match(blocking=True, timeout=0.1)
            if message is None or message.get_type() == "BAD_DATA":
                continue
            self._logged(message)
            self.inbox(message.get_srcSystem()).put(message)


# ---- one vehicle -----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class StatusReport:
    """What a vehicle last said of itself: its HEARTBEAT (mode, armed, MAV_STATE), EXTENDED_SYS_STATE (landed) and
    the last failsafe it announced."""

    mode: str | None
    armed: bool | None
    system_status: str | None
    landed: str | None
    failsafe: str | None

    def __str__(self) -> str:
        if self.mode is None:
            return "no HEARTBEAT heard"
        armed = "armed" if self.armed else "disarmed"
        landed = f", {self.landed}" if self.landed else ""
        return (f"mode {self.mode}, {armed}, MAV_STATE {self.system_status}{landed}; failsafe: "
                f"{self.failsafe or 'none announced'}")  # fmt: skip


class GroundStation:
    """A ground station talking to the vehicle of system id `target_system` through `link` (made by
    GroundLink.station or Vehicle.ground_station)."""

    def __init__(self, link: GroundLink, target_system: int) -> None:
        self.link = link
        self.target_system = target_system
        self._inbox = link.inbox(target_system)
        self._parameter_types: dict[str, int] = {}

    # ---- the raw link ------------------------------------------------------------------------------------------
    @property
    def connection(self) -> Any:
        """The pymavlink connection (mavutil), to send what the helpers do not; its thread reads it: wait for
        messages with wait_message(), not with its recv_match()."""
        return self.link.connection

    @property
    def mav(self) -> Any:
        """pymavlink's encoder: gcs.send(gcs.mav.<message>_encode(...))."""
        return self.link.connection.mav

    def send(self, message: Any) -> None:
        self.link.send(message)

    # ---- what the vehicle says -------------------------------------------------------------------------------------
    def latest(self, kind: str) -> Any | None:
        """The vehicle's latest message of type `kind` (e.g. "LOCAL_POSITION_NED"), None before the first."""
        with self._inbox.changed:
            return self._inbox.latest.get(kind)

    def wait_message(self, kind: str, condition: Callable[[Any], bool] = lambda message: True,
                     timeout_s: float = 10.0) -> Any:  # fmt: skip
        """The next message of type `kind` from the vehicle for which `condition` holds, arriving after this call;
        TimeoutError after `timeout_s` wall seconds."""
        message = self.next_message(kind, condition, timeout_s)
        if message is None:
            raise TimeoutError(f"no {kind} from vehicle {self.target_system} within {timeout_s:g} s"
                               f"{self._last_words()}")  # fmt: skip
        return message

    def next_message(self, kind: str, condition: Callable[[Any], bool] = lambda message: True,
                     timeout_s: float = 10.0) -> Any | None:  # fmt: skip
        """As wait_message(), None after `timeout_s` instead of an error."""
        found = self._inbox.wait(self._mark(), lambda m: m.get_type() == kind and condition(m), timeout_s)
        return None if found is None else found[1]

    @property
    def statustexts(self) -> list[str]:
        """Everything the vehicle announced (STATUSTEXT, whole), oldest first."""
        with self._inbox.changed:
            return list(self._inbox.statustexts)

    @property
    def mode(self) -> FlightMode | None:
        """The flight mode of the vehicle's latest HEARTBEAT (None before it, or a mode PX4 does not name)."""
        heartbeat = self.latest("HEARTBEAT")
        return None if heartbeat is None else FlightMode.of_custom_mode(heartbeat.custom_mode)

    @property
    def armed(self) -> bool:
        heartbeat = self.latest("HEARTBEAT")
        return heartbeat is not None and bool(heartbeat.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED)

    def status(self) -> StatusReport:
        heartbeat, extended = self.latest("HEARTBEAT"), self.latest("EXTENDED_SYS_STATE")
        failsafes = [text for text in self.statustexts if "failsafe" in text.lower()]
        if heartbeat is None:
            return StatusReport(None, None, None, None, failsafes[-1] if failsafes else None)
        mode = FlightMode.of_custom_mode(heartbeat.custom_mode)
        return StatusReport(
            mode=str(mode) if mode is not None else f"custom mode {heartbeat.custom_mode:#x}",
            armed=bool(heartbeat.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED),
            system_status=STATE_NAMES.get(heartbeat.system_status, str(heartbeat.system_status)),
            landed=None if extended is None else LANDED_NAMES.get(extended.landed_state),
            failsafe=failsafes[-1] if failsafes else None,
        )

    def wait_connected(self, timeout_s: float = 30.0) -> None:
        """Until the vehicle's autopilot has been heard (its HEARTBEAT)."""
        if self.latest("HEARTBEAT") is None:
            self.wait_message("HEARTBEAT", lambda m: m.get_srcComponent() == AUTOPILOT_COMPONENT, timeout_s)

    # ---- commands ----------------------------------------------------------------------------------------------
    def command(self, command: int, *params: float) -> Any:
        """COMMAND_LONG `command` with up to seven params (the rest 0) to the vehicle's autopilot: its COMMAND_ACK,
        whatever its result (resent as the module says); CommandTimeout without one."""
        return self._command(command, params)[1]

    def _command(self, command: int, params: tuple[float, ...]) -> tuple[int, Any]:
        """command(): the COMMAND_ACK and its number among the messages received."""
        if len(params) > 7:
            raise ValueError(f"COMMAND_LONG has 7 params, not {len(params)}")
        values = [float(p) for p in params] + [0.0] * (7 - len(params))
        after = self._mark()

        def answers(message: Any) -> bool:
            return (message.get_type() == "COMMAND_ACK" and message.command == command
                    and message.get_srcComponent() == AUTOPILOT_COMPONENT)  # fmt: skip

        for confirmation in range(COMMAND_RETRIES + 1):
            self.send(self.mav.command_long_encode(self.target_system, AUTOPILOT_COMPONENT, command, confirmation,
                                                   *values))  # fmt: skip
            found = self._inbox.wait(after, answers, ACK_TIMEOUT_S)
            while found is not None and found[1].result == M.MAV_RESULT_IN_PROGRESS:
                found = self._inbox.wait(found[0], answers, IN_PROGRESS_TIMEOUT_S)
            if found is not None:
                return found
        raise CommandTimeout(f"{_command_name(command)}: no COMMAND_ACK from vehicle {self.target_system} after "
                             f"{COMMAND_RETRIES + 1} sends {ACK_TIMEOUT_S:g} s apart{self._last_words()}")  # fmt: skip

    def command_accepted(self, command: int, *params: float) -> Any:
        """command(), and CommandRefused (with the vehicle's reason) unless the result is MAV_RESULT_ACCEPTED."""
        number, ack = self._command(command, params)
        if ack.result != M.MAV_RESULT_ACCEPTED:
            raise CommandRefused(f"{_command_name(command)} refused by vehicle {self.target_system} "
                                 f"({RESULT_NAMES.get(ack.result, ack.result)}){self._reason(number)}",
                                 ack.result)  # fmt: skip
        return ack

    def arm(self) -> None:
        """MAV_CMD_COMPONENT_ARM_DISARM 1; CommandRefused with the pre-arm failure otherwise."""
        self.command_accepted(M.MAV_CMD_COMPONENT_ARM_DISARM, 1.0)

    def disarm(self, force: bool = False) -> None:
        """Disarm (on the ground; `force`: even in flight, PX4's 21196)."""
        self.command_accepted(M.MAV_CMD_COMPONENT_ARM_DISARM, 0.0, FORCE_DISARM if force else 0.0)

    def set_mode(self, mode: FlightMode | str) -> None:
        """MAV_CMD_DO_SET_MODE to a PX4 mode by name ("HOLD", "OFFBOARD", "MISSION", "RETURN" ...)."""
        wanted = mode if isinstance(mode, FlightMode) else FlightMode.named(mode)
        self.command_accepted(M.MAV_CMD_DO_SET_MODE, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, wanted.main_mode,
                              wanted.sub_mode)  # fmt: skip

    def takeoff(self, altitude_m: float | None = None) -> None:
        """MAV_CMD_NAV_TAKEOFF to `altitude_m` above home (None: the vehicle's MIS_TAKEOFF_ALT); arm first."""
        if altitude_m is None:
            self.command_accepted(M.MAV_CMD_NAV_TAKEOFF, *[math.nan] * 7)
            return
        amsl = self.home_altitude_amsl() + altitude_m  # PX4 takes param7 above mean sea level, as MAVSDK sends it
        self.command_accepted(M.MAV_CMD_NAV_TAKEOFF, *[math.nan] * 6, amsl)

    def land(self) -> None:
        """MAV_CMD_NAV_LAND where the vehicle is."""
        self.command_accepted(M.MAV_CMD_NAV_LAND, 0.0, 0.0, 0.0, math.nan, math.nan, math.nan, math.nan)

    def home_altitude_amsl(self, timeout_s: float = 10.0) -> float:
        """Home's altitude above mean sea level (m), from the vehicle's HOME_POSITION (asked for when not heard)."""
        home = self.latest("HOME_POSITION")
        if home is None:
            self.command_accepted(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_HOME_POSITION)
            home = self.latest("HOME_POSITION") or self.wait_message("HOME_POSITION", timeout_s=timeout_s)
        return home.altitude / 1000.0

    def inject_failure(self, unit: str, failure_type: str = "off", instance: int = 0,
                       value: float = math.nan) -> None:  # fmt: skip
        """A failure, as PX4's `failure` command does: SYS_FAILURE_EN set to 1 if it is not, then
        MAV_CMD_INJECT_FAILURE. unit: motor, servo, gyro, accel, mag, baro, gps, airspeed; failure_type: off, stuck,
        wrong, ok (clears); instance: 1-based, 0 = every one; value: STUCK's angle (deg) or thrust fraction, WRONG's
        remaining fraction (NaN: where it is now / 0.5), aircraft/failures.py."""
        params = failure_params(unit, failure_type, instance, value)
        if self.get_parameter("SYS_FAILURE_EN") != 1:
            self.set_parameter("SYS_FAILURE_EN", 1)
        self.command_accepted(M.MAV_CMD_INJECT_FAILURE, *params)

    # ---- parameters --------------------------------------------------------------------------------------------
    def get_parameter(self, name: str) -> float:
        """PARAM_REQUEST_READ: the parameter's value (asked again if unanswered, as ground stations do)."""
        request = self.mav.param_request_read_encode(self.target_system, AUTOPILOT_COMPONENT, name.encode(), -1)
        return self._parameter_exchange(name, request)

    def set_parameter(self, name: str, value: float) -> float:
        """PARAM_SET: the value the vehicle answers with (its old value when it refuses; the reason in its
        STATUSTEXT)."""
        if name not in self._parameter_types:
            self.get_parameter(name)
        kind = self._parameter_types[name]
        encoded = encode_parameter(value, kind)
        return self._parameter_exchange(name, self.mav.param_set_encode(self.target_system, AUTOPILOT_COMPONENT,
                                                                        name.encode(), encoded, kind))  # fmt: skip

    def _parameter_exchange(self, name: str, request: Any) -> float:
        after = self._mark()
        for _ in range(PARAMETER_RETRIES + 1):
            self.send(request)
            found = self._inbox.wait(after, lambda m: m.get_type() == "PARAM_VALUE" and m.param_id == name,
                                     PARAMETER_TIMEOUT_S)  # fmt: skip
            if found is not None:
                answer = found[1]
                self._parameter_types[name] = answer.param_type
                return decode_parameter(answer.param_value, answer.param_type)
        raise CommandTimeout(f"parameter {name}: no PARAM_VALUE from vehicle {self.target_system} after "
                             f"{PARAMETER_RETRIES + 1} requests{self._last_words()}")  # fmt: skip

    # ---- missions ----------------------------------------------------------------------------------------------
    def upload_mission(self, items: Sequence[MissionItem], mission_type: int = MISSION) -> None:
        """The mission protocol's upload (MISSION_COUNT, each MISSION_REQUEST_INT answered with its
        MISSION_ITEM_INT, the vehicle's MISSION_ACK) of a mission, a geofence or rally points (`mission_type`,
        MAV_MISSION_TYPE_*); CommandRefused with the vehicle's MAV_MISSION_RESULT and reason, CommandTimeout."""
        what = TYPE_NAMES.get(mission_type, f"mission type {mission_type}")
        since = len(self.statustexts)
        after = self._mark()

        def reply(message: Any) -> bool:
            return (message.get_type() in ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK")
                    and message.mission_type == mission_type)  # fmt: skip

        count = self.mav.mission_count_encode(self.target_system, AUTOPILOT_COMPONENT, len(items), mission_type)
        answer = None
        for _ in range(MISSION_RETRIES + 1):
            self.send(count)
            answer = self._inbox.wait(after, reply, MISSION_TIMEOUT_S)
            if answer is not None:
                break
        deadline = time.monotonic() + MISSION_UPLOAD_TIMEOUT_S
        while answer is not None and answer[1].get_type() != "MISSION_ACK":
            seq = answer[1].seq
            if not 0 <= seq < len(items):
                raise CommandRefused(f"{what} upload: the vehicle asked for item {seq} of {len(items)}",
                                     M.MAV_MISSION_INVALID_SEQUENCE)  # fmt: skip
            self.send(self._item(items[seq], seq, mission_type))
            answer = self._inbox.wait(answer[0], reply, max(0.0, deadline - time.monotonic()))
        if answer is None:
            raise CommandTimeout(f"{what} upload to vehicle {self.target_system}: no answer{self._last_words()}")
        result = answer[1].type
        if result != M.MAV_MISSION_ACCEPTED:
            entry = M.enums["MAV_MISSION_RESULT"].get(result)
            raise CommandRefused(f"{what} upload refused by vehicle {self.target_system} "
                                 f"({entry.name if entry else result}){self._said_since(since)}", result)  # fmt: skip

    def _item(self, item: MissionItem, seq: int, mission_type: int) -> Any:
        return self.mav.mission_item_int_encode(
            self.target_system, AUTOPILOT_COMPONENT, seq, item.frame, item.command, int(seq == 0), item.autocontinue,
            item.param1, item.param2, item.param3, item.param4, item.x, item.y, item.z, mission_type,
        )  # fmt: skip

    # ---- inner workings ----------------------------------------------------------------------------------------
    def _mark(self) -> int:
        with self._inbox.changed:
            return self._inbox.received

    def _said_since(self, since: int) -> str:
        """The last whole STATUSTEXT after the first `since` (": <text>", or ""), waited for briefly."""
        said = self._inbox.wait_statustexts(since, REASON_WAIT_S)
        return f": {said[-1]}" if said else ""

    def _reason(self, ack_number: int) -> str:
        """What the vehicle said after its refusal, which it says right after the answer (the message numbered
        `ack_number`), in one or more chunks (": <text>", or ""). A text that came before the answer (e.g. the
        "Armed" of an earlier command, read late) is not the reason."""
        found = self._inbox.wait(ack_number, lambda message: message.get_type() == "STATUSTEXT", REASON_WAIT_S)
        if found is None:
            return ""
        first = found[1]
        if first.id == 0:
            return f": {first.text}"
        deadline = time.monotonic() + REASON_WAIT_S  # a text in chunks: the whole of it, once its last chunk came
        while time.monotonic() < deadline:
            whole = next((text for text in reversed(self.statustexts) if text.startswith(first.text)), None)
            if whole is not None:
                return f": {whole}"
            time.sleep(0.01)
        return f": {first.text}"

    def _last_words(self) -> str:
        said = self.statustexts[-3:]
        return f"; its last STATUSTEXT: {said}" if said else ""


def _command_name(command: int) -> str:
    entry = M.enums["MAV_CMD"].get(command)
    return entry.name if entry is not None else f"command {command}"
