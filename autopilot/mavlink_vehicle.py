"""The autopilot as a PX4-like MAVLink vehicle on its ground-station links (SPEC sections 2, 5 and 8).

Two UDP links, both bound on 127.0.0.1:

    GCS  binds 18570+I, sends to 127.0.0.1:14550+I until a client speaks, then to the clients
    API  binds 14580+I, sends to 127.0.0.1:14540+I until a client speaks, then to the clients (MAVSDK)

A client is any sender of a valid MAVLink message; a link serves its MAX_CLIENTS most recent ones (so a second
script, or a ground station restarted on another port, is answered too). Until a client speaks, the streams
run at most at 2 Hz, which keeps an unconnected autopilot cheap.

Everything runs inside the plant loop, once per plant step, after the step's SERVO_OUTPUT_RAW has gone to the
plant (so this work overlaps the plant's): the sockets are drained without blocking, the messages handled,
and the telemetry streams that are due (in simulation time) are sent, several frames per datagram.

Every input is untrusted: the parser drops and counts bad frames; commands, set-points and parameter values
are checked and refused with a reason (COMMAND_ACK + STATUSTEXT, PARAM_VALUE with the unchanged value).
"""

from __future__ import annotations

import json
import math
import select
import socket
import sys
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from autopilot import commander as cmd
from autopilot.commander import Commander, custom_mode, mode_from_px4, px4_mode_name
from autopilot.parameters import MAV_TYPE_OF, ParameterRejected, ParameterStore, decode_value, encode_value
from autopilot.vehicle_state import VehicleState
from transport.geodesy import Home
from transport.mavlink import Link, mavlink
from transport.ports import LOOPBACK

M = mavlink
RECEIVE_SIZE = 65536
DATAGRAM_LIMIT = 1200  # bytes: frames are batched into datagrams up to about this size (PX4 batches too)
MAX_CLIENTS = 4  # per link: the most recent distinct senders get the link's traffic (a tiny MAVLink router)
MAX_DATAGRAMS_PER_STEP = 16  # per link and step, and at most INPUT_BUDGET_S of work: a flood cannot starve the
INPUT_BUDGET_S = 0.0002  # control loop (what is left waits in the socket; the kernel drops what does not fit)
MAX_DATAGRAM_BYTES = 4096  # MAVLink over UDP is one or a few frames (<= 280 bytes each) per datagram: bigger is junk
MIN_INTERVAL_USEC = 2500  # one plant step: the fastest a stream can go
IDLE_INTERVAL_USEC = 500_000  # until a client speaks on a link, no stream runs faster than 2 Hz there
NOTICE_PERIOD_USEC = 1_000_000  # the same refusal is said at most once per simulated second,
NOTICES_PER_PERIOD = 20  # and at most this many refusals in all (a flood of varied junk cannot flood the links)
INJECTION_TIMEOUT_USEC = 1_000_000  # the plant must acknowledge a forwarded failure within this
HOLD_POLL_MS = 100  # --offboard-lockstep: a held step waits for datagrams this long between checks for a stop,
HOLD_RESEND_S = 1.0  # says where the simulation stands again after this long without an answer,
HOLD_NOTICE_S = 5.0  # and tells the terminal once after this long
SETPOINT_LIMITS = np.array([30.0, 30.0, 10.0])  # m/s: the MPC's velocity envelope (SPEC 4.3)
COMP_ID = 1
FORCE = cmd.FORCE_MAGIC

# Telemetry streams and their default rates (Hz), SPEC section 5.
DEFAULT_RATES_HZ: dict[int, float] = {
    M.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
    M.MAVLINK_MSG_ID_SYS_STATUS: 2.0,
    M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 2.0,
    M.MAVLINK_MSG_ID_ATTITUDE: 50.0,
    M.MAVLINK_MSG_ID_ATTITUDE_QUATERNION: 50.0,
    M.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 30.0,
    M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 30.0,
    M.MAVLINK_MSG_ID_VFR_HUD: 10.0,
    M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: 20.0,
    M.MAVLINK_MSG_ID_GPS_RAW_INT: 5.0,
    M.MAVLINK_MSG_ID_BATTERY_STATUS: 1.0,
    M.MAVLINK_MSG_ID_HOME_POSITION: 0.5,
    M.MAVLINK_MSG_ID_SYSTEM_TIME: 1.0,
}
REQUEST_ONLY = (M.MAVLINK_MSG_ID_AUTOPILOT_VERSION,)

SENSORS = (
    M.MAV_SYS_STATUS_SENSOR_3D_GYRO | M.MAV_SYS_STATUS_SENSOR_3D_ACCEL | M.MAV_SYS_STATUS_SENSOR_3D_MAG
    | M.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE | M.MAV_SYS_STATUS_SENSOR_DIFFERENTIAL_PRESSURE
    | M.MAV_SYS_STATUS_SENSOR_GPS | M.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL
    | M.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION | M.MAV_SYS_STATUS_SENSOR_YAW_POSITION
    | M.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL | M.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
    | M.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS | M.MAV_SYS_STATUS_AHRS | M.MAV_SYS_STATUS_SENSOR_BATTERY
    | M.MAV_SYS_STATUS_PREARM_CHECK
)  # fmt: skip
CAPABILITIES = (
    M.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE | M.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    | M.MAV_PROTOCOL_CAPABILITY_COMMAND_INT | M.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
    | M.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
)  # fmt: skip
# The PX4 protocol level this vehicle behaves like (QGroundControl checks it); ours is in flight_custom_version.
PX4_VERSION = (1 << 24) | (15 << 16) | (0 << 8) | 255  # 1.15.0 release
CUSTOM_VERSION = list(b"trsitl01")

LOCAL_FRAMES = {M.MAV_FRAME_LOCAL_NED: False, M.MAV_FRAME_LOCAL_OFFSET_NED: False, M.MAV_FRAME_BODY_NED: True,
                M.MAV_FRAME_BODY_OFFSET_NED: True, M.MAV_FRAME_BODY_FRD: True}  # fmt: skip  (True: yaw-rotated)
GLOBAL_FRAMES = (M.MAV_FRAME_GLOBAL, M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_FRAME_GLOBAL_INT,
                 M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_FRAME_GLOBAL_TERRAIN_ALT,
                 M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT)  # fmt: skip
POSITION_IGNORE = 0b111
VELOCITY_IGNORE = 0b111 << 3

TAKES_EFFECT_LATER = {"MAV_SYS_ID": "from the next start",
                      "VT_CTRL": "from the next start or takeoff from the ground"}  # fmt: skip
FAILURE_UNITS = {M.FAILURE_UNIT_SYSTEM_MOTOR: ("motor", 4), M.FAILURE_UNIT_SYSTEM_SERVO: ("servo", 8)}
FAILURE_TYPES = {M.FAILURE_TYPE_OK: "OK", M.FAILURE_TYPE_OFF: "OFF", M.FAILURE_TYPE_STUCK: "STUCK",
                 M.FAILURE_TYPE_WRONG: "WRONG"}  # fmt: skip


def _interval_usec(rate_hz: float) -> int:
    return int(round(1e6 / rate_hz))


def _int_param(value: float) -> int | None:
    """A command parameter that must be an integer: its value, or None if it is not one."""
    if not math.isfinite(value) or value != int(value):
        return None
    return int(value)


@dataclass
class Origin:
    """Who asked (for the COMMAND_ACK): the link and the sender's ids."""

    link: GroundLink
    system: int
    component: int
    command: int


@dataclass
class LinkCounters:
    received: int = 0
    sent_datagrams: int = 0
    send_failed: int = 0
    ignored: Counter[str] = field(default_factory=Counter)


class GroundLink:
    """One UDP MAVLink link to ground stations (GCS or API)."""

    def __init__(self, name: str, bind_port: int, remote_port: int, system_id: int) -> None:
        self.name = name
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.bind((LOOPBACK, bind_port))
        except OSError:
            self.sock.close()
            raise
        self.sock.setblocking(False)
        self.bind_port = self.sock.getsockname()[1]
        self.default_remote = (LOOPBACK, remote_port)
        self.clients: list[tuple[str, int]] = []  # most recent first
        self.link = Link(system_id, COMP_ID)
        self.intervals = {msgid: _interval_usec(rate) for msgid, rate in DEFAULT_RATES_HZ.items()}
        self.next_due = {msgid: 0 for msgid in self.intervals}
        self.next_any_due = 0
        self.out = bytearray()
        self.counters = LinkCounters()

    @property
    def remotes(self) -> list[tuple[str, int]]:
        return self.clients or [self.default_remote]

    def heard(self, sender: tuple[str, int]) -> bool:
        """A valid message from `sender`; True if it is the link's first client."""
        first = not self.clients
        if not self.clients or self.clients[0] != sender:
            if sender in self.clients:
                self.clients.remove(sender)
            self.clients.insert(0, sender)
            del self.clients[MAX_CLIENTS:]
        return first

    def close(self) -> None:
        self.sock.close()

    def receive(self, deadline: float):
        """Datagrams waiting in the socket (sender too), until MAX_DATAGRAMS_PER_STEP or the deadline (perf_counter)."""
        for _ in range(MAX_DATAGRAMS_PER_STEP):
            try:
                data, sender = self.sock.recvfrom(RECEIVE_SIZE)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:  # ICMP "port unreachable" from an earlier send to a closed port: not data
                continue
            if len(data) > MAX_DATAGRAM_BYTES:
                self.link.dropped["oversized_datagram"] += 1
                continue
            yield data, sender
            if time.perf_counter() >= deadline:
                return

    def queue(self, message: Any) -> None:
        self.out += self.link.pack(message)
        if len(self.out) >= DATAGRAM_LIMIT:
            self.flush()

    def flush(self) -> None:
        if not self.out:
            return
        data = bytes(self.out)
        self.out = bytearray()
        for remote in self.clients or (self.default_remote,):
            try:
                self.sock.sendto(data, remote)
                self.counters.sent_datagrams += 1
            except OSError:  # nobody listening (ICMP), full buffer: counted, the flight goes on
                self.counters.send_failed += 1

    def set_interval(self, msgid: int, interval_usec: int, now_usec: int) -> None:
        if interval_usec <= 0:
            self.intervals.pop(msgid, None)
            self.next_due.pop(msgid, None)
        else:
            self.intervals[msgid] = interval_usec
            self.next_due[msgid] = now_usec
        self.next_any_due = min(self.next_due.values(), default=1 << 62)

    def restart_streams(self, now_usec: int) -> None:
        for msgid in self.next_due:
            self.next_due[msgid] = now_usec
        self.next_any_due = now_usec


class MavlinkVehicle:
    """Handles the ground-station links: messages in, telemetry and answers out."""

    def __init__(
        self,
        links: list[GroundLink],
        params: ParameterStore,
        commander: Commander,
        *,
        system_id: int,
        home: Home = Home(),
        inject_failure: Callable[[int, int, int, float, Origin], None] = lambda *a: None,
        parameter_changed: Callable[[str, float], None] = lambda name, value: None,
        zenoh_session: Any | None = None,
        quiet: bool = False,
    ) -> None:
        self.links = links
        self.params = params
        self.commander = commander
        self.system_id = system_id
        self.home = home
        self.inject_failure = inject_failure
        self.parameter_changed = parameter_changed
        self.quiet = quiet
        self.now_usec = 0
        self.state = VehicleState()
        self.hil: Any = None
        self.controller: Any = None
        self.pwm: list[int] = [0] * 12
        self.setpoints_dropped = 0
        self.setpoints_clamped = 0
        self.holds = 0  # --offboard-lockstep: steps held for set-points, and the wall time spent holding
        self.hold_wall_s = 0.0
        self._last_notice: dict[str, int] = {}
        self._notice_window_usec = 0
        self._notices_in_window = 0
        self.notices_suppressed = 0
        self._text_id = 0
        self._write_error: str | None = None
        self._events = None
        self.boot_wall = time.time()
        if zenoh_session is not None:
            self._events = zenoh_session.declare_publisher(f"vtol/{system_id}/autopilot/events")
        commander.say = self.announce
        self._poll = select.poll()  # one cheap system call per step tells which link has datagrams
        self._by_fd = {}
        for link in links:
            self._poll.register(link.sock, select.POLLIN)
            self._by_fd[link.sock.fileno()] = link

    def close(self) -> None:
        for link in self.links:
            link.flush()
            link.close()

    # ---- the per-step entry point -------------------------------------------------------------------------
    def service(self, time_usec: int, state: VehicleState, hil: Any, controller: Any, pwm: list[int]) -> None:
        self.now_usec = time_usec
        self.commander.now_usec = time_usec
        self.state, self.hil, self.controller, self.pwm = state, hil, controller, pwm
        if self.params.write_error is not self._write_error:
            self._write_error = self.params.write_error
            if self._write_error:
                self.announce(M.MAV_SEVERITY_ERROR, f"Parameters not saved: {self._write_error}")
        self._serve_input(0, INPUT_BUDGET_S)
        if self.commander.state_changed:
            self.commander.state_changed = False
            for link in self.links:
                link.queue(self._heartbeat(link))
        for link in self.links:
            if time_usec >= link.next_any_due:
                self._send_due_streams(link, time_usec)
            if link.out:
                link.flush()

    def hold_for_setpoints(self, time_usec: int, state: VehicleState, hil: Any, should_stop: Callable[[], bool]) -> None:
        """--offboard-lockstep: while no stamped set-point covers `time_usec`, hold here (the plant waits for this
        step's answer) and serve the links. Each wait starts with a SYSTEM_TIME (time_boot_ms = now) on every
        link, which tells a scripted client where the simulation stands; it is repeated each HOLD_RESEND_S."""
        if self.commander.setpoints_cover(time_usec):
            return
        self.now_usec = self.commander.now_usec = time_usec
        self.state, self.hil = state, hil
        self.holds += 1
        waiting_since = sent = time.monotonic()
        said = False
        self._send_system_time()
        while not self.commander.setpoints_cover(time_usec) and not should_stop():
            ready = self._serve_input(HOLD_POLL_MS, HOLD_POLL_MS / 1000)
            for link in self.links:
                if link.out:
                    link.flush()
            now = time.monotonic()
            if not ready and now - sent >= HOLD_RESEND_S:
                self._send_system_time()
                sent = now
                if not said and now - waiting_since >= HOLD_NOTICE_S:
                    said = True
                    print(f"vtol-autopilot: --offboard-lockstep: holding the simulation at {time_usec / 1e6:.3f} s "
                          "until a client streams set-points stamped with time_boot_ms", file=sys.stderr, flush=True)
        self.hold_wall_s += time.monotonic() - waiting_since

    def _serve_input(self, wait_ms: int, budget_s: float) -> bool:
        """Handle the datagrams waiting on the links (waiting up to wait_ms for the first), within budget_s of
        work per link; True if any link had input."""
        ready = self._poll.poll(wait_ms)
        if ready:
            deadline = time.perf_counter() + budget_s
            for fd, _ in ready:
                link = self._by_fd[fd]
                for data, sender in link.receive(deadline):
                    self._handle_datagram(link, data, sender)
        return bool(ready)

    def _send_system_time(self) -> None:
        for link in self.links:
            link.queue(self._system_time(link))
            link.flush()

    def restart(self, time_usec: int) -> None:
        """The simulation clock went back: restart the stream schedules."""
        self.now_usec = time_usec
        for link in self.links:
            link.restart_streams(time_usec)
        self._last_notice.clear()

    # ---- announcements ---------------------------------------------------------------------------------------
    def announce(self, severity: int, text: str, key: str | None = None) -> None:
        """STATUSTEXT on every link (and stderr, zenoh); with a key, at most once per simulated second."""
        if key is not None:
            last = self._last_notice.get(key)
            if last is not None and 0 <= self.now_usec - last < NOTICE_PERIOD_USEC:
                self.notices_suppressed += 1
                return
            if not 0 <= self.now_usec - self._notice_window_usec < NOTICE_PERIOD_USEC:
                self._notice_window_usec, self._notices_in_window = self.now_usec, 0
                if len(self._last_notice) > 256:
                    self._last_notice.clear()
            if self._notices_in_window >= NOTICES_PER_PERIOD:
                self.notices_suppressed += 1
                return
            self._notices_in_window += 1
            self._last_notice[key] = self.now_usec
        if not self.quiet:
            print(f"vtol-autopilot: {text}", file=sys.stderr, flush=True)
        chunks = self._statustext_chunks(text)
        for link in self.links:
            for chunk, text_id, sequence in chunks:
                link.queue(link.link.mav.statustext_encode(severity, chunk, text_id, sequence))
        if self._events is not None:
            self._events.put(json.dumps({"t": self.now_usec / 1e6, "event": "statustext", "severity": severity,
                                         "text": text}).encode())  # fmt: skip

    def _statustext_chunks(self, text: str) -> list[tuple[bytes, int, int]]:
        """A text of up to 50 bytes in one STATUSTEXT (id 0); longer ones in 50-byte chunks that share an id
        (MAVLink 2; the last chunk is shorter than 50 bytes, empty if need be), as PX4 sends them."""
        encoded = text.encode("utf-8", "replace")[:50 * 20]
        if len(encoded) <= 50:
            return [(encoded, 0, 0)]
        self._text_id = self._text_id % 65535 + 1
        chunks = [encoded[i:i + 50] for i in range(0, len(encoded), 50)]
        if len(chunks[-1]) == 50:
            chunks.append(b"")
        return [(chunk, self._text_id, sequence) for sequence, chunk in enumerate(chunks)]

    def _ack(self, origin: Origin, result: int, reason: str | None = None) -> None:
        link = origin.link
        link.queue(link.link.mav.command_ack_encode(origin.command, result, 0, 0, origin.system, origin.component))
        if reason:
            severity = M.MAV_SEVERITY_WARNING if result != M.MAV_RESULT_ACCEPTED else M.MAV_SEVERITY_INFO
            self.announce(severity, reason, key=f"ack:{origin.command}:{reason}")

    def injection_done(self, origin: Origin, result: int, text: str) -> None:
        """The plant answered a forwarded MAV_CMD_INJECT_FAILURE (or did not, result FAILED)."""
        accepted = result == M.MAV_RESULT_ACCEPTED
        self._ack(origin, result)
        self.announce(M.MAV_SEVERITY_WARNING if accepted else M.MAV_SEVERITY_ERROR, text)

    # ---- receiving -----------------------------------------------------------------------------------------------
    def _handle_datagram(self, link: GroundLink, data: bytes, sender: tuple[str, int]) -> None:
        messages = link.link.parse(data)
        if messages and link.heard(sender):
            link.restart_streams(self.now_usec)  # the first client: full stream rates from now
        for message in messages:
            link.counters.received += 1
            kind = message.get_type()
            handler = self._HANDLERS.get(kind)
            if handler is None:
                link.counters.ignored[kind] += 1
                continue
            try:
                handler(self, link, message)
            except Exception as exc:  # a handler bug must never stop the flight: count it and say it
                link.counters.ignored[f"error:{kind}"] += 1
                self.announce(M.MAV_SEVERITY_ERROR, f"{kind} not handled: {type(exc).__name__}: {exc}",
                              key=f"error:{kind}")  # fmt: skip

    def _for_us(self, target_system: int, target_component: int | None = None) -> bool:
        if target_system not in (0, self.system_id):
            return False
        return target_component is None or target_component in (0, COMP_ID)

    def _on_heartbeat(self, link: GroundLink, message: Any) -> None:
        pass  # learning the client's address is all a ground station's HEARTBEAT is for

    # ---- commands -----------------------------------------------------------------------------------------------
    def _on_command_long(self, link: GroundLink, message: Any) -> None:
        if not self._for_us(message.target_system, message.target_component):
            link.counters.ignored["command_for_other"] += 1
            return
        params = (message.param1, message.param2, message.param3, message.param4, message.param5, message.param6,
                  message.param7)  # fmt: skip
        self._command(link, message, message.command, params, frame=None)

    def _on_command_int(self, link: GroundLink, message: Any) -> None:
        if not self._for_us(message.target_system, message.target_component):
            link.counters.ignored["command_for_other"] += 1
            return
        params = (message.param1, message.param2, message.param3, message.param4, float(message.x), float(message.y),
                  message.z)  # fmt: skip
        self._command(link, message, message.command, params, frame=message.frame)

    def _command(self, link: GroundLink, message: Any, command: int, p: tuple[float, ...], frame: int | None) -> None:
        origin = Origin(link, message.get_srcSystem(), message.get_srcComponent(), command)
        handler = self._COMMANDS.get(command)
        if handler is None:
            self._ack(origin, M.MAV_RESULT_UNSUPPORTED)
            return
        reply = handler(self, origin, p, frame)
        if reply is not None:
            self._ack(origin, *reply)

    def _cmd_arm(self, origin: Origin, p, frame) -> tuple[int, str | None]:
        arm = p[0]
        force = p[1] == FORCE
        if arm == 1.0:
            return self.commander.arm(self.state, force)
        if arm == 0.0:
            return self.commander.disarm(self.state, force)
        return M.MAV_RESULT_DENIED, f"Arm/disarm: param1 must be 1 or 0, not {arm:g}"

    def _cmd_takeoff(self, origin: Origin, p, frame) -> tuple[int, str | None]:
        altitude = p[6]
        if math.isnan(altitude):
            return self.commander.takeoff(self.state, None)
        if not math.isfinite(altitude):
            return M.MAV_RESULT_DENIED, "Takeoff denied: param7 (altitude) is infinite"
        relative = frame in (M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)
        above_home = altitude if relative else altitude - self.home.alt
        if not 1.0 <= above_home <= 1000.0:
            return M.MAV_RESULT_DENIED, (f"Takeoff denied: {altitude:g} m AMSL is {above_home:.0f} m above home "
                                         f"(1..1000 m; NaN: MIS_TAKEOFF_ALT)")  # fmt: skip
        return self.commander.takeoff(self.state, above_home)

    def _cmd_land(self, origin: Origin, p, frame) -> tuple[int, str | None]:
        return self.commander.land(self.state)

    def _cmd_set_mode(self, origin: Origin, p, frame) -> tuple[int, str | None]:
        base, main, sub = _int_param(p[0]), _int_param(p[1]), _int_param(p[2]) if not math.isnan(p[2]) else 0
        if base is None or main is None or sub is None:
            return M.MAV_RESULT_DENIED, "Set mode: param1..3 must be integers (base mode, PX4 main, sub mode)"
        return self._set_mode(base, main, sub)

    def _set_mode(self, base: int, main: int, sub: int) -> tuple[int, str | None]:
        if not base & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return M.MAV_RESULT_DENIED, "Set mode: only PX4 custom modes (base mode flag 1)"
        mode = mode_from_px4(main, sub)
        if mode is None:
            return M.MAV_RESULT_DENIED, f"Mode {px4_mode_name(main, sub)} not supported: Hold Takeoff Land Offboard"
        return self.commander.set_mode(mode, self.state)

    def _cmd_transition(self, origin: Origin, p, frame) -> tuple[int, str | None]:
        target = _int_param(p[0])
        if target is None:
            return M.MAV_RESULT_DENIED, "Transition: param1 must be 3 (MC) or 4 (FW)"
        return self.commander.transition(target, self.state)

    def _cmd_inject_failure(self, origin: Origin, p, frame) -> tuple[int, str | None] | None:
        if self.params.get_int("SYS_FAILURE_EN") != 1:
            return M.MAV_RESULT_DENIED, "Failure injection disabled: set SYS_FAILURE_EN to 1"
        unit, kind, instance = _int_param(p[0]), _int_param(p[1]), _int_param(p[2])
        if unit is None or kind is None or instance is None:
            return M.MAV_RESULT_DENIED, "Failure injection: unit, type and instance must be integers"
        if unit not in FAILURE_UNITS:
            return M.MAV_RESULT_UNSUPPORTED, f"Failure unit {unit} not simulated (101 motor, 102 servo)"
        if kind not in FAILURE_TYPES:
            return M.MAV_RESULT_UNSUPPORTED, f"Failure type {kind} not simulated (0 OK 1 OFF 2 STUCK 4 WRONG)"
        name, count = FAILURE_UNITS[unit]
        if not 0 <= instance <= count:
            return M.MAV_RESULT_DENIED, f"Failure injection: {name} instance {instance} not in 0..{count}"
        value = p[3]
        if math.isinf(value):
            return M.MAV_RESULT_DENIED, "Failure injection: param4 must be finite or NaN"
        self.inject_failure(unit, kind, instance, value, origin)
        return None  # acknowledged when the plant has answered

    def _cmd_request_message(self, origin: Origin, p, frame) -> tuple[int, str | None]:
        msgid = _int_param(p[0])
        message = self._build(origin.link, msgid) if msgid is not None else None
        if message is None:
            return M.MAV_RESULT_DENIED, f"Message {p[0]:g} not available on request"
        self._ack(origin, M.MAV_RESULT_ACCEPTED)
        origin.link.queue(message)
        return None

    def _cmd_capabilities(self, origin: Origin, p, frame) -> tuple[int, str | None]:
        origin.link.queue(self._autopilot_version(origin.link))
        return M.MAV_RESULT_ACCEPTED, None

    def _cmd_home(self, origin: Origin, p, frame) -> tuple[int, str | None]:
        origin.link.queue(self._home_position(origin.link))
        return M.MAV_RESULT_ACCEPTED, None

    def _cmd_set_interval(self, origin: Origin, p, frame) -> tuple[int, str | None]:
        msgid = _int_param(p[0])
        interval = p[1]
        if msgid is None or msgid not in DEFAULT_RATES_HZ:
            return M.MAV_RESULT_DENIED, f"Message interval: message {p[0]:g} is not a stream here"
        if not math.isfinite(interval) or (interval < 0 and interval != -1):
            return M.MAV_RESULT_DENIED, f"Message interval: {interval:g} us (-1 off, 0 default, >0 us)"
        if interval == 0:
            usec = _interval_usec(DEFAULT_RATES_HZ[msgid])
        elif interval == -1:
            usec = 0
        else:
            usec = max(int(interval), MIN_INTERVAL_USEC)
        origin.link.set_interval(msgid, usec, self.now_usec)
        return M.MAV_RESULT_ACCEPTED, None

    def _cmd_get_interval(self, origin: Origin, p, frame) -> tuple[int, str | None]:
        msgid = _int_param(p[0])
        if msgid is None or not 0 <= msgid < (1 << 24):
            return M.MAV_RESULT_DENIED, "Get message interval: param1 must be a message id"
        link = origin.link
        interval = link.intervals.get(msgid, 0 if msgid in DEFAULT_RATES_HZ else -1)
        self._ack(origin, M.MAV_RESULT_ACCEPTED)
        link.queue(link.link.mav.message_interval_encode(msgid, interval if interval else -1))
        return None

    _COMMANDS: dict[int, Callable] = {
        M.MAV_CMD_COMPONENT_ARM_DISARM: _cmd_arm,
        M.MAV_CMD_NAV_TAKEOFF: _cmd_takeoff,
        M.MAV_CMD_NAV_LAND: _cmd_land,
        M.MAV_CMD_DO_SET_MODE: _cmd_set_mode,
        M.MAV_CMD_DO_VTOL_TRANSITION: _cmd_transition,
        M.MAV_CMD_INJECT_FAILURE: _cmd_inject_failure,
        M.MAV_CMD_REQUEST_MESSAGE: _cmd_request_message,
        M.MAV_CMD_SET_MESSAGE_INTERVAL: _cmd_set_interval,
        M.MAV_CMD_GET_MESSAGE_INTERVAL: _cmd_get_interval,
        M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: _cmd_capabilities,
        M.MAV_CMD_GET_HOME_POSITION: _cmd_home,
    }

    def _on_set_mode(self, link: GroundLink, message: Any) -> None:
        if not self._for_us(message.target_system):
            return
        main, sub = (message.custom_mode >> 16) & 0xFF, (message.custom_mode >> 24) & 0xFF
        result, reason = self._set_mode(message.base_mode, main, sub)
        if reason:
            self.announce(M.MAV_SEVERITY_WARNING, reason, key=f"set_mode:{reason}")

    # ---- offboard set-points -------------------------------------------------------------------------------------
    def _on_position_target_local(self, link: GroundLink, message: Any) -> None:
        if not self._for_us(message.target_system, message.target_component):
            return
        rotate = LOCAL_FRAMES.get(message.coordinate_frame)
        if rotate is None:
            self._drop_setpoint(f"frame {message.coordinate_frame} not supported (LOCAL_NED, BODY_NED)")
            return
        velocity = self._setpoint_velocity(message)
        if velocity is None:
            return
        if rotate:
            yaw = float(self.state.euler[2])
            c, s = math.cos(yaw), math.sin(yaw)
            velocity = np.array([c * velocity[0] - s * velocity[1], s * velocity[0] + c * velocity[1], velocity[2]])
        self._accept_setpoint(velocity, message.time_boot_ms)

    def _on_position_target_global(self, link: GroundLink, message: Any) -> None:
        if not self._for_us(message.target_system, message.target_component):
            return
        if message.coordinate_frame not in GLOBAL_FRAMES:
            self._drop_setpoint(f"frame {message.coordinate_frame} not a global frame")
            return
        velocity = self._setpoint_velocity(message)
        if velocity is not None:
            self._accept_setpoint(velocity, message.time_boot_ms)

    def _setpoint_velocity(self, message: Any) -> np.ndarray | None:
        mask = message.type_mask
        if mask & VELOCITY_IGNORE:
            self._drop_setpoint("velocity only: type_mask must use vx vy vz")
            return None
        if (mask & POSITION_IGNORE) != POSITION_IGNORE:
            self._drop_setpoint("position set-points not supported: velocity only")
            return None
        velocity = np.array([message.vx, message.vy, message.vz], dtype=float)
        if not np.all(np.isfinite(velocity)):
            self._drop_setpoint("not finite (NaN/Inf)")
            return None
        return velocity

    def _drop_setpoint(self, why: str) -> None:
        self.setpoints_dropped += 1
        self.announce(M.MAV_SEVERITY_WARNING, f"Set-point dropped: {why}", key=f"setpoint:{why}")

    def _accept_setpoint(self, velocity: np.ndarray, stamp_ms: int) -> None:
        clamped = np.clip(velocity, -SETPOINT_LIMITS, SETPOINT_LIMITS)
        if not np.array_equal(clamped, velocity):
            self.setpoints_clamped += 1
            self.announce(M.MAV_SEVERITY_WARNING, "Set-point clamped to |v| <= (30, 30, 10) m/s", key="clamped")
        self.commander.offboard_setpoint(clamped, stamp_ms)

    # ---- parameters -----------------------------------------------------------------------------------------------
    def _param_value(self, link: GroundLink, index: int) -> Any:
        definition = self.params.definitions[index]
        value = encode_value(definition, self.params[definition.name])
        return link.link.mav.param_value_encode(definition.name.encode(), value, MAV_TYPE_OF[definition.kind],
                                                len(self.params), index)  # fmt: skip

    def _on_param_request_list(self, link: GroundLink, message: Any) -> None:
        if not self._for_us(message.target_system, message.target_component):
            return
        for index in range(len(self.params)):
            link.queue(self._param_value(link, index))

    def _on_param_request_read(self, link: GroundLink, message: Any) -> None:
        if not self._for_us(message.target_system, message.target_component):
            return
        if message.param_index >= 0:
            if message.param_index >= len(self.params):
                self.announce(M.MAV_SEVERITY_WARNING, f"Param read: index {message.param_index} not in "
                              f"0..{len(self.params) - 1}", key="param_index")  # fmt: skip
                return
            link.queue(self._param_value(link, message.param_index))
            return
        name = message.param_id
        if name not in self.params.index:
            self.announce(M.MAV_SEVERITY_WARNING, f"Param read: unknown {name!r}", key=f"param_unknown:{name}")
            return
        link.queue(self._param_value(link, self.params.index[name]))

    def _on_param_set(self, link: GroundLink, message: Any) -> None:
        if not self._for_us(message.target_system, message.target_component):
            return
        name = message.param_id
        definition = self.params.definition(name)
        if definition is None:
            self.announce(M.MAV_SEVERITY_WARNING, f"Param set: unknown {name!r}", key=f"param_unknown:{name}")
            return
        index = self.params.index[name]
        expected = MAV_TYPE_OF[definition.kind]
        if message.param_type != expected:
            self.announce(M.MAV_SEVERITY_WARNING, f"Param set {name}: type {message.param_type}, need {expected}",
                          key=f"param_type:{name}")  # fmt: skip
            link.queue(self._param_value(link, index))
            return
        value = decode_value(definition, message.param_value)
        try:
            changed = self.params.set(name, value)
        except ParameterRejected as refusal:
            self.announce(M.MAV_SEVERITY_WARNING, f"Param set refused: {refusal}", key=f"param_refused:{name}")
            link.queue(self._param_value(link, index))
            return
        if changed:
            self.parameter_changed(name, self.params[name])
            if name in TAKES_EFFECT_LATER:
                self.announce(M.MAV_SEVERITY_INFO, f"{name} = {self.params[name]:g} {TAKES_EFFECT_LATER[name]}")
            for other in self.links:  # a change goes to every link, as PX4 broadcasts it
                other.queue(self._param_value(other, index))
        else:
            link.queue(self._param_value(link, index))

    # ---- missions (none) and time sync ---------------------------------------------------------------------------
    def _on_mission_request_list(self, link: GroundLink, message: Any) -> None:
        if not self._for_us(message.target_system):
            return
        link.queue(link.link.mav.mission_count_encode(message.get_srcSystem(), message.get_srcComponent(), 0,
                                                      message.mission_type))  # fmt: skip

    def _on_mission_count(self, link: GroundLink, message: Any) -> None:
        if not self._for_us(message.target_system):
            return
        result = M.MAV_MISSION_ACCEPTED if message.count == 0 else M.MAV_MISSION_UNSUPPORTED
        if message.count:
            self.announce(M.MAV_SEVERITY_WARNING, "Missions not supported: fly with modes and Offboard",
                          key="mission")  # fmt: skip
        link.queue(link.link.mav.mission_ack_encode(message.get_srcSystem(), message.get_srcComponent(), result,
                                                    message.mission_type))  # fmt: skip

    def _on_mission_clear_all(self, link: GroundLink, message: Any) -> None:
        if not self._for_us(message.target_system):
            return
        link.queue(link.link.mav.mission_ack_encode(message.get_srcSystem(), message.get_srcComponent(),
                                                    M.MAV_MISSION_ACCEPTED, message.mission_type))  # fmt: skip

    def _on_timesync(self, link: GroundLink, message: Any) -> None:
        if message.tc1 == 0:
            link.queue(link.link.mav.timesync_encode(self.now_usec * 1000, message.ts1))

    _HANDLERS: dict[str, Callable] = {
        "HEARTBEAT": _on_heartbeat,
        "COMMAND_LONG": _on_command_long,
        "COMMAND_INT": _on_command_int,
        "SET_MODE": _on_set_mode,
        "SET_POSITION_TARGET_LOCAL_NED": _on_position_target_local,
        "SET_POSITION_TARGET_GLOBAL_INT": _on_position_target_global,
        "PARAM_REQUEST_LIST": _on_param_request_list,
        "PARAM_REQUEST_READ": _on_param_request_read,
        "PARAM_SET": _on_param_set,
        "MISSION_REQUEST_LIST": _on_mission_request_list,
        "MISSION_COUNT": _on_mission_count,
        "MISSION_CLEAR_ALL": _on_mission_clear_all,
        "TIMESYNC": _on_timesync,
    }

    # ---- telemetry -------------------------------------------------------------------------------------------------
    def _send_due_streams(self, link: GroundLink, now: int) -> None:
        next_any = 1 << 62
        for msgid, due in link.next_due.items():
            if now >= due:
                message = self._build(link, msgid)
                if message is not None:
                    link.queue(message)
                interval = link.intervals[msgid]
                if not link.clients and interval < IDLE_INTERVAL_USEC:
                    interval = IDLE_INTERVAL_USEC
                due += interval
                if due <= now:  # fell behind (or restarted): from now on
                    due = now + interval
                link.next_due[msgid] = due
            if due < next_any:
                next_any = due
        link.next_any_due = next_any

    def _build(self, link: GroundLink, msgid: int) -> Any | None:
        builder = self._BUILDERS.get(msgid)
        if builder is None or (self.hil is None and msgid not in (0, 148, 242, 1, 245, 2, 147)):
            return None
        return builder(self, link)

    @property
    def time_boot_ms(self) -> int:
        return (self.now_usec // 1000) & 0xFFFFFFFF

    def _heartbeat(self, link: GroundLink) -> Any:
        c = self.commander
        base = M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | M.MAV_MODE_FLAG_STABILIZE_ENABLED | \
            M.MAV_MODE_FLAG_GUIDED_ENABLED | M.MAV_MODE_FLAG_AUTO_ENABLED  # fmt: skip
        if c.armed:
            base |= M.MAV_MODE_FLAG_SAFETY_ARMED
        status = M.MAV_STATE_ACTIVE if c.armed else M.MAV_STATE_STANDBY
        if not c.started:
            status = M.MAV_STATE_BOOT
        return link.link.mav.heartbeat_encode(M.MAV_TYPE_VTOL_TILTROTOR, M.MAV_AUTOPILOT_PX4, base,
                                              custom_mode(c.mode), status)  # fmt: skip

    def _sys_status(self, link: GroundLink) -> Any:
        health = SENSORS if self.commander.started else SENSORS & ~M.MAV_SYS_STATUS_PREARM_CHECK
        return link.link.mav.sys_status_encode(SENSORS, SENSORS, health, 0, 16800, -1, 100, 0, 0, 0, 0, 0, 0)

    def _extended_sys_state(self, link: GroundLink) -> Any:
        return link.link.mav.extended_sys_state_encode(self._vtol_state(), self.commander.landed_state)

    def _vtol_state(self) -> int:
        controller = self.controller
        if controller is None:
            return M.MAV_VTOL_STATE_MC
        tilt = controller.servos.tilt
        mean = (tilt[0] + tilt[1] + tilt[2] + tilt[3]) * 0.25
        if mean < 0.0873:  # 5 deg
            return M.MAV_VTOL_STATE_MC
        if mean > 1.4835:  # 85 deg
            return M.MAV_VTOL_STATE_FW
        commanded = float(np.mean(controller.command[4:8]))
        return M.MAV_VTOL_STATE_TRANSITION_TO_FW if commanded >= mean else M.MAV_VTOL_STATE_TRANSITION_TO_MC

    def _attitude(self, link: GroundLink) -> Any:
        s = self.state
        roll, pitch, yaw = s.euler.tolist()
        p, q, r = s.body_rates.tolist()
        return link.link.mav.attitude_encode(self.time_boot_ms, roll, pitch, yaw, p, q, r)

    def _attitude_quaternion(self, link: GroundLink) -> Any:
        s = self.state
        w, x, y, z = s.quaternion.tolist()
        p, q, r = s.body_rates.tolist()
        return link.link.mav.attitude_quaternion_encode(self.time_boot_ms, w, x, y, z, p, q, r)

    def _local_position(self, link: GroundLink) -> Any:
        s = self.state
        x, y, z = s.position_ned.tolist()
        vx, vy, vz = s.velocity_ned.tolist()
        return link.link.mav.local_position_ned_encode(self.time_boot_ms, x, y, z, vx, vy, vz)

    def _heading_cdeg(self) -> int:
        return int(round(math.degrees(float(self.state.euler[2])) * 100)) % 36000

    def _global_position(self, link: GroundLink) -> Any:
        h = self.hil
        relative = int(round(-float(self.state.position_ned[2]) * 1000))
        return link.link.mav.global_position_int_encode(self.time_boot_ms, h.lat, h.lon, h.alt, relative, h.vx, h.vy,
                                                        h.vz, self._heading_cdeg())  # fmt: skip

    def _gps_raw(self, link: GroundLink) -> Any:
        h = self.hil
        vn, ve = float(self.state.velocity_ned[0]), float(self.state.velocity_ned[1])
        cog = int(round(math.degrees(math.atan2(ve, vn)) * 100)) % 36000 if math.hypot(vn, ve) > 0.1 else 65535
        return link.link.mav.gps_raw_int_encode(self.now_usec, M.GPS_FIX_TYPE_3D_FIX, h.lat, h.lon, h.alt, 70, 100,
                                                int(round(math.hypot(vn, ve) * 100)), cog, 12)  # fmt: skip

    def _vfr_hud(self, link: GroundLink) -> Any:
        s = self.state
        throttle = 0
        if self.commander.armed and self.controller is not None:
            throttle = int(round(float(np.mean(self.controller.command[0:4])) * 100)) if self.commander.flying else 0
        heading = self._heading_cdeg() // 100
        return link.link.mav.vfr_hud_encode(s.airspeed, math.hypot(s.velocity_ned[0], s.velocity_ned[1]), heading,
                                            throttle, self.hil.alt / 1000.0, -float(s.velocity_ned[2]))  # fmt: skip

    def _servo_output(self, link: GroundLink) -> Any:
        return link.link.mav.servo_output_raw_encode(self.now_usec & 0xFFFFFFFF, 0, *self.pwm[0:12])

    def _battery(self, link: GroundLink) -> Any:
        return link.link.mav.battery_status_encode(0, M.MAV_BATTERY_FUNCTION_ALL, M.MAV_BATTERY_TYPE_LIPO, 32767,
                                                   [4200] * 4 + [65535] * 6, -1, -1, -1, 100)  # fmt: skip

    def _home_position(self, link: GroundLink) -> Any:
        h = self.home
        return link.link.mav.home_position_encode(int(round(h.lat * 1e7)), int(round(h.lon * 1e7)),
                                                  int(round(h.alt * 1000)), 0.0, 0.0, 0.0, [1.0, 0.0, 0.0, 0.0],
                                                  0.0, 0.0, 0.0, self.now_usec)  # fmt: skip

    def _system_time(self, link: GroundLink) -> Any:
        return link.link.mav.system_time_encode(int(time.time() * 1e6), self.time_boot_ms)

    def _autopilot_version(self, link: GroundLink) -> Any:
        return link.link.mav.autopilot_version_encode(CAPABILITIES, PX4_VERSION, 0, 0, 0, CUSTOM_VERSION, [0] * 8,
                                                      [0] * 8, 0, 0, 0x5452_5300 + self.system_id)  # fmt: skip

    _BUILDERS: dict[int, Callable] = {
        M.MAVLINK_MSG_ID_HEARTBEAT: _heartbeat,
        M.MAVLINK_MSG_ID_SYS_STATUS: _sys_status,
        M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: _extended_sys_state,
        M.MAVLINK_MSG_ID_ATTITUDE: _attitude,
        M.MAVLINK_MSG_ID_ATTITUDE_QUATERNION: _attitude_quaternion,
        M.MAVLINK_MSG_ID_LOCAL_POSITION_NED: _local_position,
        M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: _global_position,
        M.MAVLINK_MSG_ID_VFR_HUD: _vfr_hud,
        M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: _servo_output,
        M.MAVLINK_MSG_ID_GPS_RAW_INT: _gps_raw,
        M.MAVLINK_MSG_ID_BATTERY_STATUS: _battery,
        M.MAVLINK_MSG_ID_HOME_POSITION: _home_position,
        M.MAVLINK_MSG_ID_SYSTEM_TIME: _system_time,
        M.MAVLINK_MSG_ID_AUTOPILOT_VERSION: _autopilot_version,
    }

    # ---- summary -----------------------------------------------------------------------------------------------------
    def summary(self) -> dict[str, Any]:
        return {
            link.name.lower(): {
                "port": link.bind_port,
                "clients": [f"{host}:{port}" for host, port in link.clients],
                "received": link.counters.received,
                "sent_datagrams": link.counters.sent_datagrams,
                "send_failed": link.counters.send_failed,
                "dropped": dict(link.link.dropped),
                "ignored": dict(link.counters.ignored),
            }
            for link in self.links
        } | {"setpoints_dropped": self.setpoints_dropped, "setpoints_clamped": self.setpoints_clamped,
             "notices_suppressed": self.notices_suppressed,
             "lockstep_holds": self.holds, "lockstep_hold_wall_s": round(self.hold_wall_s, 3),
             "mode": self.commander.mode, "armed": self.commander.armed}  # fmt: skip
