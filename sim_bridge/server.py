"""The plant link (docs/plant-link.md): UDP MAVLink on 127.0.0.1:4560+I, lockstep by default, real time on request.

Lockstep: for each step k the plant sends the state at t_k, then waits for SERVO_OUTPUT_RAW stamped
t_k mod 2^32 before it integrates to t_{k+1}. If none comes within the timeout it holds the last command,
counts a missed step and goes on, so a silent peer never hangs the plant; after `peer_lost_after` missed
steps in a row it pauses (not stepping) until an autopilot speaks again, then resends the current state.
Paced (`--realtime`, interactive sessions): the same lockstep, paced to the wall clock times the speed factor.
When the autopilot cannot keep up (a busy machine) the simulation slows down instead of integrating on a stale
command, and says so (achieved speed factor on stderr, to the autopilot as STATUSTEXT, on zenoh, in the summary),
as PX4 SITL with its lockstep simulators does.
Free-running (`--realtime --free-running`, explicit): paced to the wall clock with whatever command is latest,
however old; a slow autopilot then flies on stale commands (the vehicle can fall on a busy machine).

Everything received is untrusted: the Link parser drops and counts bad frames; out-of-range PWM is
clamped and counted; commands for other components are ignored and counted.
"""

from __future__ import annotations

import socket
import sys
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

from aircraft.actuators import pwm_to_command
from aircraft.failures import FailureRejected
from sim_bridge.peer import Address, PeerGate
from sim_bridge.plant import DT, Plant
from sim_bridge.plant_parameters import PlantParameterService
from sim_bridge.sensors import SensorSuite
from transport.mavlink import (
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_UNSUPPORTED,
    Link,
    mavlink,
)
from transport.telemetry import PlantStateBatch, encode_event, plant_events_key, plant_state_key
from transport.udp import SPIN_WINDOW_S, receive

USEC_WRAP = 1 << 32
LAG_LIMIT_S = 0.05  # paced: this far behind the wall clock, the schedule moves (the simulation slows down)
SPEED_WINDOW_S = 2.0  # wall seconds over which the achieved speed factor is measured
SLOW_FRACTION = 0.9  # below this fraction of the speed asked for, the slowdown is said
SLOW_NOTICE_S = 10.0  # at most once per this many wall seconds

MAX_DATAGRAM_BYTES = 4096  # a plant-link datagram is one state (<= 300 bytes) or a few frames: bigger is junk


class Pacing(Enum):
    LOCKSTEP = "lockstep"  # every step waits for its command; as fast as both processes go
    PACED = "paced"  # lockstep, and no faster than the wall clock times the speed factor
    FREE_RUNNING = "free-running"  # the wall clock times the speed factor, with the latest command whatever its age


@dataclass
class PlantCounters:
    """What the plant did with its input, reported at exit by --summary."""

    steps: int = 0
    commands_used: int = 0
    missed_commands: int = 0  # lockstep steps that timed out and held the last command
    peer_lost: int = 0  # times the peer stayed silent for peer_lost_after steps and the plant paused for it
    stale_commands: int = 0  # SERVO_OUTPUT_RAW for another step than the one awaited
    pwm_clamped: int = 0
    ignored: Counter[str] = field(default_factory=Counter)
    failures_applied: int = 0
    failures_rejected: int = 0
    misaddressed_commands: int = 0  # COMMAND_LONGs from the peer for another system or component: DENIED
    slowdowns: int = 0  # paced: times the simulation fell behind the wall clock and slowed down


class PlantServer:
    """Runs a Plant behind its MAVLink socket."""

    def __init__(
        self,
        plant: Plant,
        sock: socket.socket,
        link: Link,
        sensors: SensorSuite,
        *,
        pacing: Pacing = Pacing.LOCKSTEP,
        speed: float = 1.0,
        lockstep_timeout_s: float = 0.5,
        peer_lost_after: int = 10,
        duration_s: float | None = None,
        zenoh_session: Any | None = None,
        should_stop: Callable[[], bool] = lambda: False,
        autopilot: Address | None = None,
        parameters: PlantParameterService | None = None,
    ) -> None:
        """`autopilot`: the only address that may become the peer (`--autopilot-port`); None: the first autopilot
        to complete the handshake. `parameters`: the plant's parameters (the wind), which the peer may read and set
        (None: the plant's wind as it is, and no parameters)."""
        self.plant = plant
        self.parameters = parameters
        self.sock = sock
        self.link = link
        self.sensors = sensors
        self.pacing = pacing
        self.lockstep = pacing != Pacing.FREE_RUNNING  # every step waits for its command
        self.speed = speed
        self.timeout_s = lockstep_timeout_s
        self.peer_lost_after = peer_lost_after
        self.max_steps = None if duration_s is None else int(round(duration_s / DT))
        self.should_stop = should_stop
        self.gate = PeerGate(link, self._send, autopilot)
        self.counters = PlantCounters()
        self.system_id = link.mav.srcSystem
        self.component_id = link.mav.srcComponent
        self._state_publisher = None
        self._event_publisher = None
        self._states = PlantStateBatch()
        if zenoh_session is not None:
            self._state_publisher = zenoh_session.declare_publisher(plant_state_key(self.system_id))
            self._event_publisher = zenoh_session.declare_publisher(plant_events_key(self.system_id))
        self._awaited_usec = -1
        self._got_command = False
        self.wall_time_s = 0.0
        self.wait_time_s = 0.0  # time spent waiting for datagrams; the rest of wall time is the plant's work
        self.achieved_speed: float | None = None  # paced: over the last SPEED_WINDOW_S
        self._pace_start = 0.0  # paced: wall time (monotonic) of step 0 on the current schedule
        self._window = (0.0, 0)  # paced: (wall time, step) where the current speed window began
        self._slow_said = -SLOW_NOTICE_S

    @property
    def peer(self) -> Address | None:
        """The autopilot the plant belongs to (None until one completes the handshake)."""
        return self.gate.peer

    # ---- receiving -------------------------------------------------------------------------------------
    def _handle_datagram(self, data: bytes, sender: Address) -> None:
        if len(data) > MAX_DATAGRAM_BYTES:  # junk: parsing 60 kB of it would cost ~0.1 s of the plant's time
            self.link.dropped["oversized_datagram"] += 1
            self.gate.admit([], sender)  # counted in `foreign` when it is not the peer's
            return
        for message in self.gate.admit(self.link.parse(data), sender):
            kind = message.get_type()
            if kind == "SERVO_OUTPUT_RAW":
                self._handle_servo_output(message)
            elif kind == "COMMAND_LONG":
                self._handle_command(message, sender)
            elif kind in ("PARAM_SET", "PARAM_REQUEST_LIST", "PARAM_REQUEST_READ") and self.parameters is not None:
                self._answer_parameters(message, sender)
            elif kind in ("HEARTBEAT", "PING"):  # the peer's liveness and handshake: nothing to do
                pass
            else:
                self.counters.ignored[kind] += 1

    def _handle_servo_output(self, message: Any) -> None:
        if message.port != 0:
            self.counters.ignored["servo_output_raw_port"] += 1
            return
        if self.lockstep and message.time_usec != self._awaited_usec:
            self.counters.stale_commands += 1
            return
        pwm = [
            message.servo1_raw, message.servo2_raw, message.servo3_raw, message.servo4_raw,
            message.servo5_raw, message.servo6_raw, message.servo7_raw, message.servo8_raw,
            message.servo9_raw, message.servo10_raw, message.servo11_raw, message.servo12_raw,
        ]  # fmt: skip
        decoded = pwm_to_command(self.plant.airframe, pwm, self.plant.command)
        self.counters.pwm_clamped += decoded.clamped
        self.plant.set_command(decoded.command)
        self.counters.commands_used += 1
        self._got_command = True

    def _handle_command(self, message: Any, sender: tuple[str, int]) -> None:
        if message.target_system not in (0, self.system_id) or message.target_component not in (0, self.component_id):
            # The link is point to point: a command from our peer for other ids is a misaddressed one, refused
            # aloud (a silent drop would look like a lost datagram to the sender, who waits and times out).
            self.counters.misaddressed_commands += 1
            text = (f"command {message.command} for {message.target_system}/{message.target_component} refused: "
                    f"this plant is {self.system_id}/{self.component_id}")  # fmt: skip
            print(f"vtol-sim: {text}", file=sys.stderr, flush=True)
            self._acknowledge(message, MAV_RESULT_DENIED, sender)
            self._announce(f"plant: {text}", mavlink.MAV_SEVERITY_ERROR, sender, event="refusal")
            return
        if message.command != mavlink.MAV_CMD_INJECT_FAILURE:
            self.counters.ignored["command_unsupported"] += 1
            self._acknowledge(message, MAV_RESULT_UNSUPPORTED, sender)
            return
        try:
            lines = self.plant.inject_failure(message.param1, message.param2, message.param3, message.param4)
        except FailureRejected as refusal:
            self.counters.failures_rejected += 1
            result = MAV_RESULT_UNSUPPORTED if refusal.unsupported else MAV_RESULT_DENIED
            self._acknowledge(message, result, sender)
            self._announce(f"plant: failure refused: {refusal}", mavlink.MAV_SEVERITY_WARNING, sender)
            return
        self.counters.failures_applied += 1
        self._acknowledge(message, MAV_RESULT_ACCEPTED, sender)
        for line in lines:
            self._announce(f"plant: {line}", mavlink.MAV_SEVERITY_WARNING, sender)

    def _answer_parameters(self, message: Any, sender: tuple[str, int]) -> None:
        assert self.parameters is not None
        answer = self.parameters.answer(message)
        for value in answer.values:
            self._send(self.link.pack(value), sender)
        for text, refused in answer.said:
            print(f"vtol-sim: {text}", file=sys.stderr, flush=True)
            severity = mavlink.MAV_SEVERITY_WARNING if refused else mavlink.MAV_SEVERITY_INFO
            self._announce(f"plant: {text}", severity, sender, event="refusal" if refused else "parameter")

    def _acknowledge(self, message: Any, result: int, sender: tuple[str, int]) -> None:
        ack = self.link.mav.command_ack_encode(
            message.command, result, 0, 0, message.get_srcSystem(), message.get_srcComponent()
        )
        self._send(self.link.pack(ack), sender)

    def _announce(self, text: str, severity: int, sender: tuple[str, int], event: str = "failure") -> None:
        status = self.link.mav.statustext_encode(severity, text.encode()[:50])
        self._send(self.link.pack(status), sender)
        if self._event_publisher is not None:
            self._publish_states()  # the states before the event go out first
            self._event_publisher.put(encode_event(self.plant.time_usec / 1e6, event, text))

    def _send(self, data: bytes, address: tuple[str, int]) -> None:
        try:
            self.sock.sendto(data, address)
        except OSError:  # full socket buffer or vanished peer: counted, the simulation goes on
            self.counters.ignored["send_failed"] += 1

    def _receive_until(self, deadline: float, stop_on_command: bool, stop_on_peer: bool = False) -> None:
        """Handle datagrams until the deadline (monotonic s), or until the awaited command arrived
        (`stop_on_command`), or until an autopilot completed the handshake (`stop_on_peer`)."""
        while (not (stop_on_command and self._got_command) and not (stop_on_peer and self.peer is not None)
               and not self.should_stop()):  # fmt: skip
            waiting_since = time.monotonic()
            if waiting_since >= deadline:
                return
            # Spin only in lockstep, where the answer comes within ~100 us; in real time the next event is a
            # wall-clock deadline milliseconds away, and spinning would burn a core for nothing.
            received = None
            if self.lockstep:
                received = receive(self.sock, min(deadline, waiting_since + SPIN_WINDOW_S), spin_s=SPIN_WINDOW_S)
            if received is None:
                publishing = time.monotonic()
                self._publish_states()  # about to block: no sample waits on zenoh while the plant is idle
                waiting_since += time.monotonic() - publishing  # the plant's work, not waiting
                received = receive(self.sock, deadline, spin_s=0.0)
            self.wait_time_s += time.monotonic() - waiting_since
            if received is not None:
                self._handle_datagram(*received)

    def _drain(self) -> None:
        """Handle whatever is already queued, without waiting."""
        while (received := receive(self.sock, deadline=0.0, spin_s=0.0)) is not None:
            self._handle_datagram(*received)

    # ---- the loop ----------------------------------------------------------------------------------------
    def wait_for_peer(self) -> bool:
        """Block until an autopilot completes the handshake."""
        while self.peer is None:
            if self.should_stop():
                return False
            self._receive_until(time.monotonic() + 0.25, stop_on_command=False, stop_on_peer=True)
        return True

    def _send_state(self) -> None:
        plant = self.plant
        if self.peer is not None:
            self._send(self.sensors.datagram(), self.peer)
        if self._state_publisher is not None:
            self._states.add(plant.time_usec / 1e6, plant.state, plant.specific_force, float(plant.airspeed[0]),
                             float(plant.on_ground[0]), plant.command)  # fmt: skip
            if self._states.full:
                self._publish_states()

    def _publish_states(self) -> None:
        """Put the plant states gathered since the last put (one payload, docs/telemetry.md)."""
        if self._state_publisher is not None and len(self._states):
            self._state_publisher.put(self._states.take())

    def run(self) -> PlantCounters:
        """Run until the duration is reached or a stop is requested."""
        if not self.wait_for_peer():
            return self.counters
        start = time.monotonic()
        self._pace_start = start
        self._window = (start, 0)
        self.wait_time_s = 0.0
        silent_steps = 0
        plant = self.plant
        while not self.should_stop():
            self._send_state()
            if self.max_steps is not None and plant.step_count >= self.max_steps:
                break
            if self.lockstep:
                self._awaited_usec = plant.time_usec % USEC_WRAP
                self._got_command = False
                self._receive_until(time.monotonic() + self.timeout_s, stop_on_command=True)
                if not self._got_command:
                    if self.should_stop():
                        break
                    self.counters.missed_commands += 1
                    silent_steps += 1
                    if silent_steps >= self.peer_lost_after:
                        # The autopilot is gone: pause (not integrate in slow motion) until one speaks again.
                        self.counters.peer_lost += 1
                        print(
                            f"vtol-sim: no command for {silent_steps} steps; paused at t = "
                            f"{plant.time_usec / 1e6:.4f} s until an autopilot completes the handshake",
                            file=sys.stderr,
                            flush=True,
                        )
                        self.gate.release()
                        if not self.wait_for_peer():
                            break
                        silent_steps = 0
                        continue  # resend this step's state to the (new) peer, then wait for its answer
                    if self.pacing == Pacing.PACED:
                        continue  # never integrate on a stale command: resend the state, wait again
                else:
                    silent_steps = 0
            if self.pacing == Pacing.PACED:
                self._pace()
            elif self.pacing == Pacing.FREE_RUNNING:
                if time.monotonic() - self.gate.last_heard > self.peer_lost_after * self.timeout_s:
                    self.counters.peer_lost += 1  # free-running has no missed steps: silence in wall time
                    self.gate.release()
                    if not self.wait_for_peer():
                        break
                self._drain()
                deadline = start + (plant.step_count + 1) * DT / self.speed
                self._receive_until(deadline, stop_on_command=False)
            plant.step()
            self.counters.steps += 1
        self._publish_states()
        self.wall_time_s = time.monotonic() - start
        return self.counters

    def _pace(self) -> None:
        """Paced lockstep: wait for the wall clock to reach this step's time; when the loop is behind it by more
        than LAG_LIMIT_S, move the schedule (slow down) rather than race to catch up."""
        plant = self.plant
        deadline = self._pace_start + (plant.step_count + 1) * DT / self.speed
        now = time.monotonic()
        if now < deadline:
            self._receive_until(deadline, stop_on_command=False)
        elif now - deadline > LAG_LIMIT_S:
            self._pace_start = now - (plant.step_count + 1) * DT / self.speed
            self.counters.slowdowns += 1
        window_start, window_step = self._window
        if now - window_start >= SPEED_WINDOW_S:
            self.achieved_speed = (plant.step_count - window_step) * DT / (now - window_start)
            self._window = (now, plant.step_count)
            if self.achieved_speed < SLOW_FRACTION * self.speed and now - self._slow_said >= SLOW_NOTICE_S:
                self._slow_said = now
                text = (f"plant: slowed to x{self.achieved_speed:.2f} of x{self.speed:g}: the autopilot cannot keep "
                        "up (lockstep holds)")  # fmt: skip
                print(f"vtol-sim: {text}", file=sys.stderr, flush=True)
                if self.peer is not None:
                    self._announce(text, mavlink.MAV_SEVERITY_WARNING, self.peer, event="slowdown")

    def summary(self) -> dict[str, Any]:
        c = self.counters
        sim_time = self.plant.time_usec / 1e6
        busy = self.wall_time_s - self.wait_time_s
        return {
            "steps": c.steps,
            "sim_time_s": sim_time,
            "wall_time_s": round(self.wall_time_s, 3),
            "real_time_factor": round(sim_time / self.wall_time_s, 2) if self.wall_time_s > 0 else None,
            "busy_time_s": round(busy, 3),
            "plant_alone_real_time_factor": round(sim_time / busy, 2) if busy > 0 else None,
            "commands_used": c.commands_used,
            "missed_commands": c.missed_commands,
            "peer_lost": c.peer_lost,
            "stale_commands": c.stale_commands,
            "pwm_clamped": c.pwm_clamped,
            "ignored": dict(c.ignored),
            "dropped": dict(self.link.dropped),
            "failures_applied": c.failures_applied,
            "failures_rejected": c.failures_rejected,
            "misaddressed_commands": c.misaddressed_commands,
            "pacing": self.pacing.value,
            "speed": self.speed if self.pacing != Pacing.LOCKSTEP else None,
            "slowdowns": c.slowdowns,
            **self.gate.summary(),
        }
