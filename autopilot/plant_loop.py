"""The autopilot's side of the lockstep plant link: one control step per plant step, in simulation time.

Every HIL_STATE_QUATERNION gets its SERVO_OUTPUT_RAW answer. A silent plant is waited for (with a HEARTBEAT
every 0.25 s so a restarted plant finds us again; a clock that goes back restarts the schedule and the
profile); garbage from the plant is dropped, counted, and said.

What flies is decided by the Commander (arming, modes; commander.py): while it says "flying" the flight
controller runs and its velocity set-point comes from the commander at the controller's 100 Hz; on the ground
the rotors are off (disarmed) or idle (armed), and the controller does not run. A takeoff starts a fresh
flight controller (`controller_factory`), told again about every failure it should know. After the step's
answer has gone to the plant, the MAVLink vehicle (ground-station links) does its work, overlapping the plant's.
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
from autopilot.commander import Commander
from autopilot.controller_choice import set_pid_airspeeds
from autopilot.flight_controller import FlightController
from autopilot.mpc_controller import solution_summary
from autopilot.vehicle_state import VehicleState, update_from_hil_state
from transport.geodesy import Home, LocalGeodetic
from transport.mavlink import MAV_RESULT_ACCEPTED, MAV_RESULT_FAILED, mavlink
from transport.plant_link import PlantLinkClient
from transport.telemetry import control_key, encode_control, encode_mpc_solution, mpc_key

SILENCE_NOTICE_S = 1.0
LOG_PERIOD_USEC = 10_000  # the log is written at the velocity controller's 100 Hz
GROUND_TICK_USEC = 10_000  # the commander's 100 Hz while the flight controller is not running
IDLE_THRUST = 0.1  # rotor thrust fraction when armed on the ground (PX4 spins its motors at idle)
INJECTION_TIMEOUT_USEC = 1_000_000  # a forwarded failure the plant has not acknowledged by then has failed

LOG_COLUMNS = (
    ["t", "north", "east", "down", "vn", "ve", "vd", "roll", "pitch", "yaw", "p", "q", "r", "airspeed"]
    + ["vn_sp", "ve_sp", "vd_sp", "roll_sp", "pitch_sp", "yaw_sp"]
    + [f"tilt_cmd{i}" for i in range(1, 5)]
    + [f"tilt_est{i}" for i in range(1, 5)]
    + [f"u{i}" for i in range(1, 9)]
    + ["residual_force", "residual_moment", "mode"]
)

UNIT_NAMES = {101: "motor", 102: "servo"}
TYPE_NAMES = {0: "OK", 1: "OFF", 2: "STUCK", 4: "WRONG"}


@dataclass(frozen=True)
class ScheduledFailure:
    """A MAV_CMD_INJECT_FAILURE to send at a simulation time (s since the profile start)."""

    time_s: float
    unit: int
    kind: int
    instance: int
    value: float


def describe_failure(unit: int, kind: int, instance: int, value: float) -> str:
    what = f"{UNIT_NAMES.get(unit, unit)} {instance if instance else 'all'}"
    if kind == 0:
        return f"{what} OK (cleared)"
    extra = ""
    if value == value:  # not NaN
        extra = f" at {value:g} deg" if kind == 2 and unit == 102 else f" x{value:g}" if kind == 4 else f" {value:g}"
    return f"{what} {TYPE_NAMES.get(kind, kind)}{extra}"


@dataclass
class PendingInjection:
    """A failure sent to the plant, awaiting its COMMAND_ACK; origin: the ground station that asked (or None)."""

    unit: int
    kind: int
    instance: int
    value: float
    sent_usec: int
    origin: Any = None


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
        commander: Commander,
        *,
        controller_factory: Callable[[], FlightController] | None = None,
        vehicle: Any | None = None,
        params: Any | None = None,
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
        self.controller_factory = controller_factory or (lambda: FlightController(airframe))
        self.client = client
        self.commander = commander
        self.vehicle = vehicle
        self.params = params
        self.geodetic = LocalGeodetic(home)
        self.duration_usec = None if duration_s is None else int(round(duration_s * 1e6))
        self.all_failures = list(failures or [])
        self.pending_failures = sorted(self.all_failures, key=lambda f: f.time_s)
        self._last_usec = 0
        self.awaiting_ack: list[PendingInjection] = []
        self.known_failures: list[tuple[int, int, int, float]] = []  # in the order the controller learnt them
        self._knowledge_due: list[tuple[int, tuple[int, int, int, float]]] = []
        self.state = VehicleState()
        self.counters = LoopCounters()
        self.should_stop = should_stop
        self.controllers_started = 1
        self._writer = csv.writer(log) if log is not None else None
        self._publisher = None if zenoh_session is None else zenoh_session.declare_publisher(control_key(system_id))
        self._mpc_publisher = None if zenoh_session is None else zenoh_session.declare_publisher(mpc_key(system_id))
        self._published_solution = None
        if self._writer is not None:
            self._writer.writerow(LOG_COLUMNS)
        self._start_usec: int | None = None
        self._next_log_usec = 0
        self._next_ground_tick = 0
        self._dropped_reported = 0
        self._disarmed_pwm = command_to_pwm(airframe, np.zeros(12))
        idle = np.zeros(12)
        idle[0:4] = IDLE_THRUST
        self._idle_pwm = command_to_pwm(airframe, idle)
        self._hover_fraction = airframe.hover_thrust_per_rotor / airframe.thrust_max

    def _say(self, text: str) -> None:
        self.counters.notices.append(text)
        print(f"vtol-autopilot: {text}", file=sys.stderr, flush=True)

    # ---- failures ---------------------------------------------------------------------------------------------
    def request_failure(self, unit: int, kind: int, instance: int, value: float, origin: Any = None) -> None:
        """Forward a MAV_CMD_INJECT_FAILURE to the plant; the controller learns of it once the plant accepted."""
        self.client.send_command_long(mavlink.MAV_CMD_INJECT_FAILURE, (unit, kind, instance, value))
        self.awaiting_ack.append(PendingInjection(unit, kind, instance, value, self._last_usec, origin))

    def _failure_acknowledged(self, pending: PendingInjection, result: int) -> None:
        failure = (pending.unit, pending.kind, pending.instance, pending.value)
        text = describe_failure(*failure)
        if result == MAV_RESULT_ACCEPTED:
            self.counters.failures_acknowledged += 1
            delay_usec = int(round(self.params["SYS_FAILURE_DLY"] * 1e6)) if self.params is not None else 0
            if delay_usec <= 0:
                self._learn_failure(failure)
            else:
                self._knowledge_due.append((self._last_usec + delay_usec, failure))
            if self.vehicle is not None and pending.origin is not None:
                when = f", controllers told in {delay_usec / 1e6:g} s" if delay_usec > 0 else ""
                self.vehicle.injection_done(pending.origin, result, f"Failure injected: {text}{when}")
        else:
            self.counters.failures_refused += 1
            self._say(f"plant refused failure {text} (result {result})")
            if self.vehicle is not None and pending.origin is not None:
                self.vehicle.injection_done(pending.origin, result, f"Failure refused by the plant: {text}")

    def _learn_failure(self, failure: tuple[int, int, int, float]) -> None:
        self.known_failures.append(failure)
        self.controller.apply_failure(*failure)

    def _failures_due(self, t_usec: int) -> None:
        if self._knowledge_due:
            due = [item for item in self._knowledge_due if item[0] <= t_usec]
            if due:
                self._knowledge_due = [item for item in self._knowledge_due if item[0] > t_usec]
                for _, failure in due:
                    self._learn_failure(failure)
        while self.awaiting_ack and t_usec - self.awaiting_ack[0].sent_usec > INJECTION_TIMEOUT_USEC:
            pending = self.awaiting_ack.pop(0)
            self.counters.failures_refused += 1
            text = describe_failure(pending.unit, pending.kind, pending.instance, pending.value)
            self._say(f"the plant did not acknowledge failure {text}")
            if self.vehicle is not None and pending.origin is not None:
                self.vehicle.injection_done(pending.origin, MAV_RESULT_FAILED,
                                            f"Failure {text}: the plant did not answer")  # fmt: skip

    def _handle_plant_messages(self) -> None:
        for message in self.client.received_other:
            if message.get_type() == "COMMAND_ACK" and message.command == mavlink.MAV_CMD_INJECT_FAILURE:
                if self.awaiting_ack:
                    self._failure_acknowledged(self.awaiting_ack.pop(0), message.result)
            elif message.get_type() == "STATUSTEXT":
                if self.vehicle is not None:
                    self.vehicle.announce(message.severity, message.text)
                else:
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
            self.request_failure(failure.unit, failure.kind, failure.instance, failure.value)

    # ---- the controller ---------------------------------------------------------------------------------------
    def _new_controller(self) -> None:
        """A fresh flight controller (takeoff from the ground): nothing integrated before carries over."""
        self.controller = self.controller_factory()
        self.controllers_started += 1
        for failure in self.known_failures:
            self.controller.apply_failure(*failure)

    def parameter_changed(self, name: str, value: float) -> None:
        """A parameter the running controller uses changed (VT_ARSP_*): hand it over."""
        if name in ("VT_ARSP_BLEND", "VT_ARSP_TRANS") and self.params is not None:
            set_pid_airspeeds(self.controller, self.params["VT_ARSP_BLEND"], self.params["VT_ARSP_TRANS"])

    def _publish(self, t: float) -> None:
        c = self.controller
        self._publisher.put(
            encode_control(t, c.mode, c.velocity_setpoint, c.velocity_command.euler_sp, c.command[4:8],
                           np.concatenate((c.command[0:4], c.command[8:12])), c.wrench_sp, c.residual)
        )  # fmt: skip
        mpc = c.mpc
        if mpc is not None and mpc.last_solution is not None and mpc.last_solution is not self._published_solution:
            # The MPC's latest solve (SPEC 6): predicted velocities and tilts, solve time, iterations, status.
            self._published_solution = mpc.last_solution
            self._mpc_publisher.put(encode_mpc_solution(t, solution_summary(mpc.last_solution)))

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

    def _control(self, t_usec: int, t: float) -> list[int] | None:
        """The commander's 100 Hz tick and the controller's step; the PWM to send (None: the controller's)."""
        commander = self.commander
        if commander.flying:
            tick = self.controller.velocity_due(t_usec)
        else:
            tick = t_usec >= self._next_ground_tick
            if tick:
                self._next_ground_tick = t_usec + GROUND_TICK_USEC
        if tick:
            thrust = float(self.controller.command[0:4].mean()) if commander.flying else 0.0
            setpoint = commander.tick(self.state, t_usec, thrust)
            if commander.controller_reset:
                commander.controller_reset = False
                self._new_controller()
            if setpoint is not None and commander.flying:
                self.controller.set_velocity_setpoint(setpoint)
                if self._publisher is not None:
                    self._publish(t)
            pop_events = getattr(self.controller, "pop_events", None)  # e.g. the MPC fell back to the PID
            if pop_events is not None:
                for event in pop_events():
                    if self.vehicle is not None:
                        self.vehicle.announce(mavlink.MAV_SEVERITY_WARNING, event)
                    else:
                        self._say(event)
        if commander.flying:
            return None
        return self._idle_pwm if commander.armed else self._disarmed_pwm

    # ---- the loop ------------------------------------------------------------------------------------------------
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
                self._next_ground_tick = 0
                self.pending_failures = sorted(self.all_failures, key=lambda f: f.time_s)
                self.awaiting_ack.clear()
                self.commander.restart(self.state)
                if self.vehicle is not None:
                    self.vehicle.restart(t_usec)
            self._last_usec = t_usec
            if self._start_usec is None:
                self._start_usec = t_usec
                if not self.commander.started:
                    self.commander.start(self.state)
            t = (t_usec - self._start_usec) / 1e6
            if self.vehicle is not None:  # --offboard-lockstep: wait for the client's set-points to reach t
                self.vehicle.hold_for_setpoints(t_usec, self.state, sample.state, self.should_stop)
            self._inject_due_failures(t)
            self._failures_due(t_usec)
            fixed = self._control(t_usec, t)
            if fixed is None:
                stepped = self.controller.step(self.state)
                if stepped or pwm is None or pwm is self._idle_pwm or pwm is self._disarmed_pwm:
                    pwm = command_to_pwm(self.airframe, self.controller.command)
            else:
                pwm = fixed
            self.client.send_pwm(sample.time_usec, pwm)
            counters.steps += 1
            if self.vehicle is not None:
                self.vehicle.service(t_usec, self.state, sample.state, self.controller, pwm)
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
        summary = {
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
            "flight_mode": self.commander.mode,
            "armed": self.commander.armed,
            "controllers_started": self.controllers_started,
        }
        statistics = getattr(self.controller, "controller_statistics", None)
        if statistics is not None:
            summary["controller"] = statistics()
        if self.vehicle is not None:
            summary["links"] = self.vehicle.summary()
        return summary
