"""The autopilot's side of the lockstep plant link: one control step per plant step, in simulation time.

Every HIL_STATE_QUATERNION gets its SERVO_OUTPUT_RAW answer. A silent plant is waited for (with a HEARTBEAT
every 0.25 s so a restarted plant finds us again; a clock that goes back restarts the schedule and the
profile); garbage from the plant is dropped, counted, and said.
"""

from __future__ import annotations

import csv
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import IO, Any

import numpy as np

from aircraft.actuators import command_to_pwm
from aircraft.airframe import Airframe
from autopilot.flight_controller import FlightController
from autopilot.vehicle_state import VehicleState, update_from_hil_state
from transport.geodesy import Home, LocalGeodetic
from transport.mavlink import MAV_RESULT_ACCEPTED, mavlink
from transport.plant_link import PlantLinkClient
from transport.telemetry import control_key, encode_control

SILENCE_NOTICE_S = 1.0
LOG_PERIOD_USEC = 10_000  # the log is written at the velocity controller's 100 Hz

LOG_COLUMNS = (
    ["t", "north", "east", "down", "vn", "ve", "vd", "roll", "pitch", "yaw", "p", "q", "r", "airspeed"]
    + ["vn_sp", "ve_sp", "vd_sp", "roll_sp", "pitch_sp", "yaw_sp"]
    + [f"tilt_cmd{i}" for i in range(1, 5)]
    + [f"tilt_est{i}" for i in range(1, 5)]
    + [f"u{i}" for i in range(1, 9)]
    + ["residual_force", "residual_moment", "mode"]
)


@dataclass(frozen=True)
class ScheduledFailure:
    """A MAV_CMD_INJECT_FAILURE to send at a simulation time (s since the profile start)."""

    time_s: float
    unit: int
    kind: int
    instance: int
    value: float


@dataclass
class LoopCounters:
    steps: int = 0
    invalid_states: int = 0
    plant_silences: int = 0
    failures_acknowledged: int = 0
    failures_refused: int = 0
    busy_s: float = 0.0
    wall_s: float = 0.0
    notices: list[str] = field(default_factory=list)


class PlantLoop:
    """Runs a FlightController against the plant."""

    def __init__(
        self,
        airframe: Airframe,
        controller: FlightController,
        client: PlantLinkClient,
        setpoint: Callable[[float], np.ndarray],
        *,
        armed: bool,
        home: Home = Home(),
        duration_s: float | None = None,
        failures: list[ScheduledFailure] | None = None,
        log: IO[str] | None = None,
        zenoh_session: Any | None = None,
        system_id: int = 1,
        should_stop: Callable[[], bool] = lambda: False,
    ) -> None:
        self.airframe = airframe
        self.controller = controller
        self.client = client
        self.setpoint = setpoint
        self.armed = armed
        self.geodetic = LocalGeodetic(home)
        self.duration_usec = None if duration_s is None else int(round(duration_s * 1e6))
        self.all_failures = list(failures or [])
        self.pending_failures = sorted(self.all_failures, key=lambda f: f.time_s)
        self._last_usec = 0
        self.awaiting_ack: list[ScheduledFailure] = []
        self.state = VehicleState()
        self.counters = LoopCounters()
        self.should_stop = should_stop
        self._writer = csv.writer(log) if log is not None else None
        self._publisher = None if zenoh_session is None else zenoh_session.declare_publisher(control_key(system_id))
        if self._writer is not None:
            self._writer.writerow(LOG_COLUMNS)
        self._start_usec: int | None = None
        self._next_log_usec = 0
        self._dropped_reported = 0
        disarmed = np.zeros(12)
        self._disarmed_pwm = command_to_pwm(airframe, disarmed)

    def _say(self, text: str) -> None:
        self.counters.notices.append(text)
        print(f"vtol-autopilot: {text}", file=sys.stderr, flush=True)

    def _handle_plant_messages(self) -> None:
        for message in self.client.received_other:
            if message.get_type() == "COMMAND_ACK" and message.command == mavlink.MAV_CMD_INJECT_FAILURE:
                if not self.awaiting_ack:
                    continue
                failure = self.awaiting_ack.pop(0)
                if message.result == MAV_RESULT_ACCEPTED:
                    self.counters.failures_acknowledged += 1
                    self.controller.apply_failure(failure.unit, failure.kind, failure.instance, failure.value)
                else:
                    self.counters.failures_refused += 1
                    self._say(f"plant refused failure {failure} (result {message.result})")
            elif message.get_type() == "STATUSTEXT":
                self._say(f"plant says: {message.text}")
        self.client.received_other.clear()
        dropped = sum(self.client.link.dropped.values())
        if dropped > self._dropped_reported:
            self._say(f"dropped {dropped - self._dropped_reported} bad frame(s) from the plant "
                      f"({dict(self.client.link.dropped)})")  # fmt: skip
            self._dropped_reported = dropped

    def _inject_due_failures(self, t: float) -> None:
        while self.pending_failures and self.pending_failures[0].time_s <= t:
            failure = self.pending_failures.pop(0)
            self.client.send_command_long(
                mavlink.MAV_CMD_INJECT_FAILURE, (failure.unit, failure.kind, failure.instance, failure.value)
            )
            self.awaiting_ack.append(failure)

    def _publish(self, t: float) -> None:
        c = self.controller
        self._publisher.put(
            encode_control(t, c.mode, c.velocity_setpoint, c.velocity_command.euler_sp, c.command[4:8],
                           np.concatenate((c.command[0:4], c.command[8:12])), c.wrench_sp, c.residual)
        )  # fmt: skip

    def _log(self, t: float) -> None:
        s, c = self.state, self.controller
        cmd, vc = c.command, c.velocity_command
        self._writer.writerow(
            [f"{t:.4f}"]
            + [f"{v:.5g}" for v in (*s.position_ned, *s.velocity_ned, *s.euler, *s.body_rates, s.airspeed)]
            + [f"{v:.5g}" for v in (*c.velocity_setpoint, *vc.euler_sp, *cmd[4:8], *c.servos.tilt)]
            + [f"{v:.5g}" for v in (*cmd[0:4], *cmd[8:12])]
            + [f"{float(np.linalg.norm(c.residual[0:3])):.4g}", f"{float(np.linalg.norm(c.residual[3:6])):.4g}"]
            + [vc.mode]
        )

    def run(self) -> LoopCounters:
        counters = self.counters
        start_wall = time.perf_counter()
        last_heard = time.monotonic()
        pwm: list[int] | None = None
        self.client.hello()
        while not self.should_stop():
            sample = self.client.receive_step(0.25)
            if sample is None:
                if time.monotonic() - last_heard > SILENCE_NOTICE_S:
                    counters.plant_silences += 1
                    self._say("the plant is silent; waiting for it")
                    last_heard = time.monotonic()
                self.client.hello()
                continue
            busy_from = time.perf_counter()
            last_heard = time.monotonic()
            self._handle_plant_messages()
            if not update_from_hil_state(self.state, sample.state, self.geodetic, self.airframe.gravity):
                counters.invalid_states += 1
                continue  # no answer: the plant holds the last command (and counts it)
            t_usec = self.state.time_usec
            if self._start_usec is not None and t_usec < self._last_usec:
                self._say(f"the plant's clock went back ({self._last_usec} -> {t_usec} us): a new plant run; "
                          f"restarting the profile")  # fmt: skip
                self.controller.restart_clock()
                self._start_usec = None
                self._next_log_usec = 0
                self.pending_failures = sorted(self.all_failures, key=lambda f: f.time_s)
            self._last_usec = t_usec
            if self._start_usec is None:
                self._start_usec = t_usec
            t = (t_usec - self._start_usec) / 1e6
            self._inject_due_failures(t)
            if self.armed:
                if self.controller.velocity_due(t_usec):
                    self.controller.set_velocity_setpoint(self.setpoint(t))
                    if self._publisher is not None:
                        self._publish(t)
                if self.controller.step(self.state) or pwm is None:
                    pwm = command_to_pwm(self.airframe, self.controller.command)
            else:
                pwm = self._disarmed_pwm
            self.client.send_pwm(sample.time_usec, pwm)
            counters.steps += 1
            if self._writer is not None and t_usec >= self._next_log_usec:
                self._next_log_usec = t_usec + LOG_PERIOD_USEC
                self._log(t)
            counters.busy_s += time.perf_counter() - busy_from
            # Half a plant step of tolerance: the plant rounds a duration to whole steps (2.5 ms) too.
            if self.duration_usec is not None and t_usec - self._start_usec >= self.duration_usec - 1250:
                break
        counters.wall_s = time.perf_counter() - start_wall
        return counters

    def summary(self) -> dict[str, Any]:
        c = self.counters
        sim_time = (self._last_usec - (self._start_usec or 0)) / 1e6 if c.steps else 0.0
        return {
            "steps": c.steps,
            "sim_time_s": sim_time,
            "wall_time_s": round(c.wall_s, 3),
            "real_time_factor": round(sim_time / c.wall_s, 2) if c.wall_s > 0 else None,
            "busy_us_per_step": round(c.busy_s / max(c.steps, 1) * 1e6, 1),
            "invalid_states": c.invalid_states,
            "plant_silences": c.plant_silences,
            "dropped_from_plant": dict(self.client.link.dropped),
            "failures_acknowledged": c.failures_acknowledged,
            "failures_refused": c.failures_refused,
            "allocation_fallbacks": self.controller.allocation_fallbacks,
            "mode_switches": self.controller.velocity_controller.mode_switches,
            "mode": self.controller.mode,
        }
