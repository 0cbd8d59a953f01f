"""A scripted ground station that flies a scenario through MAVLink in step with a lockstep simulation (docs/scenarios.md).

The autopilot runs with `--offboard-lockstep` (docs/mavlink.md): each time it holds the simulation for
set-points it sends SYSTEM_TIME with time_boot_ms = T, its simulation time. This client answers each such hold
with one datagram: whatever commands are due (stream rates and SYS_FAILURE_EN at the first hold, Offboard mode at
the second, the failure injection when its trigger shows in the telemetry) and then the velocity set-point
stamped with the next point at or after T of its PERIOD_MS grid. Commands therefore act at a simulation time
fixed by the telemetry alone, and set-points take effect at their stamps: a scenario flies the same each run,
however the processes happen to be scheduled.

Everything sent and received is written to a .tlog (8-byte big-endian microsecond timestamp + the raw frame,
what pymavlink's mavlogdump reads); the timestamps are the run's wall-clock start plus simulation time.
"""

from __future__ import annotations

import math
import socket
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, BinaryIO

import numpy as np

from aircraft.actuators import CHANNELS, TILTS, pwm_to_command
from aircraft.airframe import Airframe
from scenarios.experiments import Scenario, Telemetry
from transport.mavlink import MAV_RESULT_ACCEPTED, Link, mavlink

M = mavlink
PERIOD_MS = 20  # set-points at 50 Hz of simulation time (at least 20 Hz)
START_MS = 1000  # the profile starts after 1 s of hovering in Offboard: its t = 0
BATCH = 50  # set-points per answer once no trigger is pending (1 s: the profile is known ahead, fewer holds)
STREAM_RATES_HZ = {M.MAVLINK_MSG_ID_ATTITUDE: 50.0, M.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 50.0,
                   M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: 50.0}  # fmt: skip
PX4_OFFBOARD = 6  # PX4 main mode
VELOCITY_ONLY = 0b110111000111  # SET_POSITION_TARGET type_mask: use vx, vy, vz (ignore position, accel, yaw)
GCS_SYSTEM, GCS_COMPONENT = 255, M.MAV_COMP_ID_MISSIONPLANNER
SILENCE_LIMIT_S = 60.0


class ScenarioError(RuntimeError):
    """The vehicle refused a step of the scenario, or went silent."""


@dataclass
class FlightEvents:
    """What happened, in simulation time (ms of time_boot_ms)."""

    profile_start_ms: int = START_MS
    failure_ms: int | None = None
    statustexts: list[tuple[int, str]] = field(default_factory=list)
    acks: list[tuple[int, int, int]] = field(default_factory=list)  # (time_boot_ms, command, result)
    holds_answered: int = 0
    last_ms: int = 0


def grid_stamp(time_boot_ms: int, period_ms: int = PERIOD_MS) -> int:
    """The first point of the set-point grid at or after `time_boot_ms`."""
    return -(-time_boot_ms // period_ms) * period_ms


def setpoint_for(scenario: Scenario, stamp_ms: int) -> np.ndarray:
    """The scenario's velocity set-point for simulation time `stamp_ms`: hover before the profile starts."""
    if stamp_ms < START_MS:
        return np.zeros(3)
    return scenario.profile((stamp_ms - START_MS) / 1000.0)


def yaw_turns(previous_deg: float, yaw_deg: float) -> int:
    """+1 when the yaw wrapped from +180 to -180 deg between two samples (a right turn), -1 the other way, else 0."""
    if yaw_deg - previous_deg < -180.0:
        return 1
    if yaw_deg - previous_deg > 180.0:
        return -1
    return 0


def tilt_commands_deg(airframe: Airframe, message: Any) -> tuple[float, float, float, float]:
    """Tilt servo commands (deg) from SERVO_OUTPUT_RAW channels 5-8."""
    pwm = [getattr(message, f"servo{i}_raw") for i in range(1, CHANNELS + 1)]
    tilts = pwm_to_command(airframe, pwm, np.zeros(CHANNELS)).command[TILTS]
    return tuple(float(np.degrees(v)) for v in tilts)  # type: ignore[return-value]


class LockstepClient:
    """Answers the autopilot's lockstep holds with the scenario's commands and set-points."""

    def __init__(
        self,
        sock: socket.socket,
        scenario: Scenario,
        airframe: Airframe,
        target_system: int,
        *,
        tlog: BinaryIO | None = None,
        on_progress: Callable[[int], None] = lambda time_boot_ms: None,
        on_first_hold: Callable[[int], None] = lambda time_boot_ms: None,
    ) -> None:
        self.sock = sock
        self.scenario = scenario
        self.airframe = airframe
        self.tlog = tlog
        self.target = target_system
        self.on_progress = on_progress
        self.on_first_hold = on_first_hold
        self.link = Link(GCS_SYSTEM, GCS_COMPONENT)
        self.telemetry = Telemetry()
        self._yaw_turns = 0  # turns to the right since the start (the yaw wraps at +-180 deg)
        self.events = FlightEvents()
        self.vehicle: tuple[str, int] | None = None
        self.covered_ms = -1
        self.mode_requested = False
        self.offboard = False
        self._wall_base_usec = int(time.time() * 1e6)
        self._now_ms = 0

    # ---- the loop -------------------------------------------------------------------------------------------
    def run(self, finished: Callable[[], bool]) -> FlightEvents:
        """Serve the flight until `finished()` (the processes have exited); raises ScenarioError."""
        self.sock.settimeout(0.2)
        heard = time.monotonic()
        while True:
            try:
                data, sender = self.sock.recvfrom(65536)
            except TimeoutError:
                if finished():
                    return self.events
                if time.monotonic() - heard > SILENCE_LIMIT_S:
                    raise ScenarioError(f"the autopilot has been silent for {SILENCE_LIMIT_S:g} s") from None
                continue
            heard = time.monotonic()
            self.vehicle = sender
            for message in self.link.parse(data):
                self._record(message)
                self._handle(message)

    def _record(self, message: Any) -> None:
        if self.tlog is not None:
            self.tlog.write(struct.pack(">Q", self._wall_base_usec + self._now_ms * 1000) + message.get_msgbuf())

    def _handle(self, message: Any) -> None:
        kind = message.get_type()
        if kind == "ATTITUDE":
            self._now_ms = max(self._now_ms, message.time_boot_ms)
            yaw_deg = math.degrees(message.yaw)
            self._yaw_turns += yaw_turns(self.telemetry.yaw_deg, yaw_deg)
            self.telemetry = replace(self.telemetry, roll_deg=math.degrees(message.roll),
                                     pitch_deg=math.degrees(message.pitch), yaw_deg=yaw_deg,
                                     yaw_unwrapped_deg=yaw_deg + 360.0 * self._yaw_turns)  # fmt: skip
        elif kind == "LOCAL_POSITION_NED":
            self.telemetry = replace(self.telemetry, ground_speed=math.hypot(message.vx, message.vy))
        elif kind == "SERVO_OUTPUT_RAW":
            self.telemetry = replace(self.telemetry, tilt_cmd_deg=tilt_commands_deg(self.airframe, message))
        elif kind == "STATUSTEXT":
            self.events.statustexts.append((self._now_ms, message.text))
        elif kind == "COMMAND_ACK":
            self.events.acks.append((self._now_ms, message.command, message.result))
            if message.command == M.MAV_CMD_DO_SET_MODE:
                if message.result != MAV_RESULT_ACCEPTED:
                    raise ScenarioError(f"Offboard refused (MAV_RESULT {message.result})")
                self.offboard = True
            elif message.command == M.MAV_CMD_INJECT_FAILURE and message.result != MAV_RESULT_ACCEPTED:
                raise ScenarioError(f"failure injection refused (MAV_RESULT {message.result})")
        elif kind == "SYSTEM_TIME" and message.time_boot_ms > self.covered_ms:
            self._now_ms = max(self._now_ms, message.time_boot_ms)
            self._answer_hold(message.time_boot_ms)

    # ---- answering a hold --------------------------------------------------------------------------------------
    def _answer_hold(self, now_ms: int) -> None:
        out: list[Any] = []
        mav = self.link.mav
        if self.events.holds_answered == 0:
            self.on_first_hold(now_ms)
            for msgid, rate in STREAM_RATES_HZ.items():
                out.append(mav.command_long_encode(self.target, 1, M.MAV_CMD_SET_MESSAGE_INTERVAL, 0, msgid,
                                                   1e6 / rate, 0, 0, 0, 0, 0))  # fmt: skip
            if self.scenario.failure is not None:
                enable = struct.unpack("<f", struct.pack("<i", 1))[0]  # PX4's bytewise INT32 encoding
                out.append(mav.param_set_encode(self.target, 1, b"SYS_FAILURE_EN", enable, M.MAV_PARAM_TYPE_INT32))
        elif not self.mode_requested:
            self.mode_requested = True
            out.append(
                mav.command_long_encode(
                    self.target,
                    1,
                    M.MAV_CMD_DO_SET_MODE,
                    0,
                    M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                    PX4_OFFBOARD,
                    0,
                    0,
                    0,
                    0,
                    0,
                )
            )
        elif now_ms >= START_MS and not self.offboard:
            raise ScenarioError("the vehicle did not acknowledge Offboard before the profile start")
        failure = self.scenario.failure
        if failure is not None and self.events.failure_ms is None and now_ms >= START_MS \
                and failure.condition(self.telemetry):  # fmt: skip
            self.events.failure_ms = now_ms
            out.append(
                mav.command_long_encode(
                    self.target, 1, M.MAV_CMD_INJECT_FAILURE, 0, *failure.injection.as_params(), 0, 0, 0
                )
            )
        # A trigger is checked at every hold, so while one is pending each answer covers one grid period.
        pending = failure is not None and self.events.failure_ms is None
        stamp = grid_stamp(now_ms)
        for _ in range(1 if pending or now_ms < START_MS else BATCH):
            velocity = setpoint_for(self.scenario, stamp)
            out.append(mav.set_position_target_local_ned_encode(stamp, self.target, 1, M.MAV_FRAME_LOCAL_NED,
                                                                VELOCITY_ONLY, 0, 0, 0, *velocity.tolist(),
                                                                0, 0, 0, 0, 0))  # fmt: skip
            self.covered_ms = stamp
            stamp += PERIOD_MS
        self.events.holds_answered += 1
        self.events.last_ms = now_ms
        datagram = b"".join(message.pack(mav) for message in out)
        for message in out:
            self._record(message)
        self.sock.sendto(datagram, self.vehicle)
        self.on_progress(now_ms)
