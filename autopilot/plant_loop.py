"""The autopilot's step loop on the lockstep plant link, in simulation time: one control step per plant step, and
the one seam between the flight stack and the MAVLink services.

Each plant step:
    1. the plant's HIL_STATE_QUATERNION becomes the state estimate; the plant's acknowledgements and texts are read
    2. with --offboard-lockstep, the MAVLink services hold the step until stamped set-points cover it
    3. failures due are injected or learnt; the commander's 100 Hz tick gives the velocity set-point; the flight
       controller runs its tasks; SERVO_OUTPUT_RAW answers the plant
    4. the services read what ground stations sent (typed requests, handled here or by the commander), then the
       loop publishes the VehicleStatus snapshot, which the services turn into telemetry: at the steps where a
       stream is due, the flight stack has news for the services (events, answered injections, arming, mode or
       ground state, home, missions) or the last snapshot is STATUS_MAX_AGE_USEC old; the other steps (most of the
       400 per second) would publish nothing, so they build none

The autopilot's clock starts at its boot, as on hardware: its time is the plant's minus the plant's time at the
first step this process saw (0 for an autopilot started with its plant; a rebooted or restarted one starts again
from 0 while the plant's clock runs on). A calibration running is fed each step's sensors and attitude.

A silent plant is waited for (with a HEARTBEAT every 0.25 s so a restarted plant finds us again); a clock that
goes back (a new plant run) restarts the autopilot's clock, the schedules and the profile; garbage from the plant is dropped, counted
and said. What flies is the commander's decision: while it says "flying" the flight controller runs; on the
ground the rotors are off (disarmed) or idle (armed). A takeoff starts a fresh flight controller from the
factory, told again about every failure it should know.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from aircraft.actuators import ROTOR_COUNT, ROTORS, SURFACES, TILTS, command_to_pwm
from aircraft.airframe import Airframe
from aircraft.failures import Failure, FailureType, FailureUnit, failed_actuators
from aircraft.rotors import RPM_PER_RAD_S, thrust_from_speed
from autopilot.commander.calibration import Calibration, Reading
from autopilot.commander.commander import Commander
from autopilot.commander.failure_detector import MotorCheck, MotorFailureDetector
from autopilot.commander.failure_injection import FailureInjection
from autopilot.commander.plant_parameter_sync import PlantParameterSync
from autopilot.commander.servo_check import MomentModel, ServoCheck, ServoJam, ServoJamDetector
from autopilot.control.flight_controller import FlightController
from autopilot.logger.control_telemetry import ControlTelemetry
from autopilot.logger.flight_log import FlightLogger
from autopilot.logger.logger import Logger
from autopilot.mavlink.services import MavlinkServices
from autopilot.storage.mission_store import MissionStore
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.home_position import HomePosition
from autopilot.topics.missions import Missions
from autopilot.topics.sensor_sample import SensorSample, calibrated, sensor_sample
from autopilot.topics.vehicle_state import VehicleState, update_from_hil_state
from autopilot.topics.vehicle_status import EventOutbox, GlobalPosition, VehicleStatus, copy_state, vtol_state
from transport.geodesy import Home, LocalGeodetic
from transport.mavlink import mavlink
from transport.plant_link import PlantLinkClient, PlantSample

SILENCE_NOTICE_S = 1.0
HELLO_REPEAT_S = 0.02  # s: the HELLO's period in the first second, until the plant's first state
GROUND_TICK_USEC = 10_000  # the commander's 100 Hz while the flight controller is not running
IDLE_THRUST = 0.1  # rotor thrust fraction when armed on the ground (PX4 spins its motors at idle)
# The services' view of the flight stack (what a request such as Go-to "here" reads) is at most this old: the
# commander's own 100 Hz, at which it acts on their requests.
STATUS_MAX_AGE_USEC = 10_000


@dataclass
class LoopCounters:
    steps: int = 0
    invalid_states: int = 0
    plant_silences: int = 0
    status_snapshots: int = 0
    busy_s: float = 0.0
    wall_s: float = 0.0
    notices: int = 0


@dataclass(frozen=True)
class LoopOutputs:
    """Where the loop writes besides the plant link: the CSV log, zenoh and the ULog logger (each optional)."""

    log: FlightLogger | None = None
    telemetry: ControlTelemetry | None = None
    ulog: Logger | None = None


def surfaces_failed(known: list[Failure]) -> bool:
    """Whether, after `known` (in the order learnt), a control surface is failed: the model has them healthy."""
    return any(SURFACES.start <= channel < SURFACES.stop for channel in failed_actuators(known))


class PlantLoop:
    """Runs the flight stack against the plant and drives the MAVLink services (None: no ground links)."""

    def __init__(
        self,
        airframe: Airframe,
        controller_factory: Callable[[], FlightController],
        client: PlantLinkClient,
        commander: Commander,
        params: ParameterStore,
        injection: FailureInjection,
        events: EventOutbox,
        *,
        services: MavlinkServices | None,
        home: Home,
        outputs: LoopOutputs = LoopOutputs(),
        duration_s: float | None = None,
        offboard_lockstep: bool = False,
        should_stop: Callable[[], bool] = lambda: False,
        missions: MissionStore | None = None,
        calibration: Calibration | None = None,
    ) -> None:
        self.airframe = airframe
        self.controller_factory = controller_factory
        self.controller = controller_factory()
        self.client = client
        self.commander = commander
        self.params = params
        self.injection = injection
        self.events = events
        self.geodetic = LocalGeodetic(home)
        self.outputs = outputs
        self.duration_usec = None if duration_s is None else int(round(duration_s * 1e6))
        self.offboard_lockstep = offboard_lockstep
        self.should_stop = should_stop
        self.services = services
        self.missions = missions if missions is not None else MissionStore()
        self.calibration = calibration
        self.boot_usec: int | None = None  # the plant's time at this process's first step
        self.plant_parameters = PlantParameterSync(params, client)
        self.motor_failures = MotorFailureDetector(airframe.rotor_speed_max, ROTOR_COUNT)
        self.detected_failures: list[Failure] = []  # what the detector told the controllers (CA_FAILURE_MODE 1)
        self.servo_jams = ServoJamDetector(MomentModel(airframe))
        self._esc_reports: list[tuple[int, float]] = []  # this step's (ESC index, RPM), checked once its time is known
        self._rotor_rpm = [math.nan] * ROTOR_COUNT  # each ESC's last report
        self.state = VehicleState()
        self.counters = LoopCounters()
        self.controllers_started = 1
        self._last_usec = 0
        self._start_usec: int | None = None
        self._next_ground_tick = 0
        self._dropped_reported = 0
        self._params_seen = params.version
        self._status_usec: int | None = None  # the last snapshot's time, home and missions
        self._status_home: HomePosition | None = None
        self._status_missions: Missions | None = None
        self._disarmed_pwm = command_to_pwm(airframe, np.zeros(12))
        idle = np.zeros(12)
        idle[ROTORS] = IDLE_THRUST
        self._idle_pwm = command_to_pwm(airframe, idle)

    def note(self, text: str) -> None:
        """A line for the terminal only (plant-link matters a ground station cannot act on)."""
        self.counters.notices += 1
        print(f"vtol-autopilot: {text}", file=sys.stderr, flush=True)

    # ---- the plant link ---------------------------------------------------------------------------------------
    def _plant_messages(self) -> None:
        self._esc_reports.clear()
        for message in self.client.received_other:
            kind = message.get_type()
            if kind == "RAW_RPM":
                self._esc_reports.append((message.index, message.frequency))
            elif kind == "COMMAND_ACK" and message.command == mavlink.MAV_CMD_INJECT_FAILURE:
                delay_s, oracle = self.params["SYS_FAILURE_DLY"], self.params["VT_FAIL_ORACLE"] == 1
                for failure in self.injection.acknowledged(message.result, self._last_usec, delay_s, oracle):
                    self._learn(failure)
            elif kind == "STATUSTEXT":
                self.events.say(message.severity, message.text)
            elif kind == "PARAM_VALUE" and (why := self.plant_parameters.answered(message)) is not None:
                self.note(why)
        self.client.received_other.clear()
        dropped = sum(self.client.link.dropped.values())
        if dropped > self._dropped_reported:
            self.note(f"dropped {dropped - self._dropped_reported} bad frame(s) from the plant "
                      f"({dict(self.client.link.dropped)})")  # fmt: skip
            self._dropped_reported = dropped

    def _check_actuators(self) -> None:
        """This step's ESC telemetry through the failure detector (armed, flying, FD_ACT_EN 1): the motor check, then
        the tilt servo check; a step without telemetry (3 in 4) has nothing to check and changes nothing."""
        if not self._esc_reports:
            return
        motors, servos, p = self.motor_failures, self.servo_jams, self.params
        for index, rpm in self._esc_reports:
            if 0 <= index < ROTOR_COUNT:
                self._rotor_rpm[index] = rpm
        if not self.commander.armed:
            if motors.failed or servos.jammed:
                self.detected_failures.clear()  # PX4 clears its motor failures at disarming
            motors.reset()
            servos.reset()
            return
        if not self.commander.flying or p["FD_ACT_EN"] != 1:
            motors.pause()
            servos.pause()
            return
        check = MotorCheck(p["FD_ACT_MOT_THR"], p["VT_FD_RPM_RATIO"], int(p["FD_ACT_MOT_TOUT"]) * 1000)
        commands = self.controller.command[ROTORS].tolist()
        for index, rpm in self._esc_reports:
            command = commands[index] if 0 <= index < ROTOR_COUNT else math.nan
            if motors.sample(index, rpm, command, self._last_usec, check):
                self._motor_failed(index, rpm, command)
        self._check_servos()

    def _check_servos(self) -> None:
        """The tilt servo check, on the model of healthy surfaces: paused while a surface failure is known."""
        if any(rpm != rpm for rpm in self._rotor_rpm):
            return  # an ESC not heard from yet
        if surfaces_failed(self.injection.known):
            self.servo_jams.pause()
            return
        p, state, controller = self.params, self.state, self.controller
        thrusts = [thrust_from_speed(self.airframe, rpm / RPM_PER_RAD_S) for rpm in self._rotor_rpm]
        check = ServoCheck(p["VT_FD_SRV_MOM"], math.radians(p["VT_FD_SRV_ANG"]), int(p["VT_FD_SRV_TOUT"]) * 1000)
        candidates = [servo for servo in range(ROTOR_COUNT) if servo not in self.motor_failures.failed]
        jam = self.servo_jams.sample(self._last_usec, state.body_rates.tolist(), thrusts,
                                     controller.servos.tilt.tolist(), controller.command[SURFACES].tolist(),
                                     state.airspeed, candidates, check)  # fmt: skip
        if jam is not None:
            self._servo_jammed(jam)

    def _servo_jammed(self, jam: ServoJam) -> None:
        """The detector found tilt servo `jam.servo` (0-based) off its estimate: a jam, said once per servo and told
        to the controllers (CA_FAILURE_MODE 1) at the tilt found, again each time it is found elsewhere; or, for a
        servo already found jammed, found where its command has it (within a healthy servo's lag): it moves again."""
        servo, degrees = jam.servo, math.degrees(jam.tilt_rad)
        lag = self.airframe.servo_tau * self.airframe.servo_rate_max  # how far a healthy servo trails its command
        command = float(self.controller.command[TILTS][servo])
        if not jam.first and abs(jam.tilt_rad - command) < math.radians(self.params["VT_FD_SRV_ANG"]) + lag:
            self._servo_freed(servo, jam.tilt_rad)
            return
        reconfigure = self.params["CA_FAILURE_MODE"] == 1
        if jam.first or reconfigure:
            self.note(f"tilt servo {servo + 1} jam detected at t = {self._last_usec / 1e6:.4f} s, at {degrees:.1f} "
                      f"deg (estimated {math.degrees(self.controller.servos.tilt[servo]):.1f} deg)")  # fmt: skip
        if jam.first:
            self.events.say(mavlink.MAV_SEVERITY_CRITICAL, f"Tilt servo {servo + 1} jam detected")
        if reconfigure:
            self._forget_detected_servo(servo)
            failure = Failure(FailureUnit.SERVO, FailureType.STUCK, servo + 1, degrees)
            self.detected_failures.append(failure)
            self._learn(failure)

    def _servo_freed(self, servo: int, tilt: float) -> None:
        """A servo found jammed follows its command again (a jam that cleared, or a finding that was wrong), found
        at `tilt` (rad): said, and the controllers fly it as healthy again from there."""
        self.note(f"tilt servo {servo + 1} follows its command again at t = {self._last_usec / 1e6:.4f} s, at "
                  f"{math.degrees(tilt):.1f} deg")  # fmt: skip
        self.events.say(mavlink.MAV_SEVERITY_INFO, f"Tilt servo {servo + 1} follows its command again")
        self.servo_jams.free(servo)
        if self._forget_detected_servo(servo):
            self._learn(Failure(FailureUnit.SERVO, FailureType.OK, servo + 1))
            self.controller.servos.observe(servo, tilt)

    def _forget_detected_servo(self, servo: int) -> bool:
        """Drop what the detector told the controllers of servo `servo` (0-based); whether it had told them."""
        kept = [f for f in self.detected_failures if not (f.unit == FailureUnit.SERVO and f.instance == servo + 1)]
        told = len(kept) < len(self.detected_failures)
        self.detected_failures[:] = kept
        return told

    def _motor_failed(self, index: int, rpm: float, command: float) -> None:
        """The detector found motor `index` (0-based) failed: said as PX4 says it, and told to the controllers with
        CA_FAILURE_MODE 1 unless the injection already told them of a failure of that motor."""
        self.note(f"motor {index + 1} failure detected at t = {self._last_usec / 1e6:.4f} s: {rpm:.0f} RPM at a "
                  f"command of {command:.2f}")  # fmt: skip
        self.events.say(mavlink.MAV_SEVERITY_CRITICAL, "Motor failure detected")
        if self.params["CA_FAILURE_MODE"] == 1 and not self._knows_motor_failure(index + 1):
            failure = Failure(FailureUnit.MOTOR, FailureType.OFF, index + 1)
            self.detected_failures.append(failure)
            self._learn(failure)

    def _knows_motor_failure(self, instance: int) -> bool:
        """The injection told the controllers of a failure of motor `instance` (1-based) that still holds (the
        latest for that motor is not OK): they fly with what it left."""
        return ROTORS.start + instance - 1 in failed_actuators(self.injection.known)

    def _restart(self, t_usec: int) -> None:
        """The plant's clock went back: a new plant run."""
        self.note(f"the plant's clock went back ({self._last_usec} -> {t_usec} us): a new plant run; "
                  f"restarting the profile")  # fmt: skip
        self.controller.restart_clock()
        self._start_usec = None
        self._next_ground_tick = 0
        if self.outputs.log is not None:
            self.outputs.log.restart()
        if self.outputs.ulog is not None:
            self.outputs.ulog.restart()
        self.injection.restart()
        self.plant_parameters.restart()
        self.commander.restart(self.state)
        if self.services is not None:
            self.services.restart(t_usec)

    # ---- the flight stack ---------------------------------------------------------------------------------------
    def _new_controller(self) -> None:
        """A fresh flight controller (takeoff from the ground): nothing integrated before carries over."""
        self.controller = self.controller_factory()
        self.controllers_started += 1
        for failure in (*self.injection.known, *self.detected_failures):
            self.controller.apply_failure(failure)

    def _learn(self, failure: Failure) -> None:
        """A failure the plant applied becomes known: the controllers' (actuators) and the failsafes' (sensors)."""
        self.controller.apply_failure(failure)
        self.commander.failure_known(failure)

    def _parameters_changed(self) -> None:
        """The running controller's gains and limits (MC_*, MPC_*, FW_*, VT_*) handed on after a change."""
        self._params_seen = self.params.version
        self.controller.retune(self.params)

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
            thrust = float(self.controller.command[ROTORS].mean()) if commander.flying else 0.0
            setpoint = commander.tick(self.state, t_usec, thrust)
            if commander.controller_reset:
                commander.controller_started()
                self._new_controller()
            if setpoint is not None and commander.flying:
                self.controller.set_velocity_setpoint(setpoint)
                self.controller.set_yaw_reference(commander.yaw_reference)
                self.controller.set_attitude_setpoint(commander.attitude_setpoint)
                if self.outputs.telemetry is not None:
                    self.outputs.telemetry.publish(t, self.controller, gather=self.client.states_come_quickly)
            elif self.outputs.telemetry is not None:
                self.outputs.telemetry.flush()  # a tick that publishes nothing: what was gathered waits no longer
            for event in self.controller.pop_events():  # e.g. the MPC fell back to the PID
                self.events.say(mavlink.MAV_SEVERITY_WARNING, event)
        if commander.flying:
            return None
        if commander.armed:
            return self._idle_pwm
        return commander.outputs_on_ground(self._disarmed_pwm, t_usec)

    def _status_due(self, t_usec: int) -> bool:
        """Whether this step builds a VehicleStatus for the services (step 4 of the module's docstring)."""
        last = self._status_usec
        return (last is None or not 0 <= t_usec - last < STATUS_MAX_AGE_USEC
                or self.services is not None and self.services.streams_due(t_usec)
                or bool(self.events.pending) or self.injection.has_outcomes or self.commander.state_changed
                or self.commander.home is not self._status_home
                or self.missions.snapshot is not self._status_missions)  # fmt: skip

    def _status(self, t_usec: int, sample: PlantSample, pwm: list[int]) -> VehicleStatus:
        self.counters.status_snapshots += 1
        self._status_usec = t_usec
        self._status_home, self._status_missions = self.commander.home, self.missions.snapshot
        c, report, hil = self.controller, self.commander.report(), sample.state
        throttle = int(round(sum(c.command[ROTORS].tolist()) / ROTOR_COUNT * 100)) if report.flying else 0
        return VehicleStatus(
            time_usec=t_usec, started=report.started, armed=report.armed, mode=report.mode,
            landed_state=report.landed_state, flying=report.flying,
            vtol_state=vtol_state(c.servos.tilt, c.command[TILTS]), state_version=report.state_version,
            estimate=copy_state(self.state),
            position=GlobalPosition(hil.lat, hil.lon, hil.alt, hil.vx, hil.vy, hil.vz),
            home=self.commander.home, pwm=tuple(pwm), throttle_percent=throttle, controller=c.kind,
            failures=(*self.injection.known, *self.detected_failures), motors_failed=tuple(self.motor_failures.failed),
            servos_jammed=tuple(self.servo_jams.jammed),
            events=self.events.drain(),
            injections=self.injection.drain_outcomes(), missions=self.missions.snapshot, terminated=report.terminated,
            sensors=self._calibrated_sensors(t_usec),
            battery=report.battery,
        )  # fmt: skip

    def _sensors(self, t_usec: int) -> SensorSample | None:
        """This step's simulated sensors, raw (decoded only when asked for: a status, a calibration)."""
        hil_sensor = self.client.latest_sensor()
        return None if hil_sensor is None else sensor_sample(hil_sensor, t_usec)

    def _calibrated_sensors(self, t_usec: int) -> SensorSample | None:
        sample = self._sensors(t_usec)
        if sample is None:
            return None
        p = self.params
        return calibrated(sample, (p["CAL_GYRO0_XOFF"], p["CAL_GYRO0_YOFF"], p["CAL_GYRO0_ZOFF"]))

    # ---- the loop ------------------------------------------------------------------------------------------------
    def run(self) -> LoopCounters:
        start_wall = time.perf_counter()
        try:
            self._fly(self.counters)
        finally:
            if self.outputs.telemetry is not None:
                self.outputs.telemetry.flush()  # what was gathered goes out however the loop ends
        self.counters.wall_s = time.perf_counter() - start_wall
        return self.counters

    def _fly(self, counters: LoopCounters) -> None:
        """Answer the plant's states until a stop is asked for or the duration is flown."""
        started = last_heard = time.monotonic()
        pwm: list[int] | None = None
        self.client.hello()
        while not self.should_stop():
            # In the first second, until the plant first answers, the HELLO is repeated often: one sent before the
            # plant bound its port is lost, and start-up would wait on the next.
            starting = self.boot_usec is None and time.monotonic() - started < SILENCE_NOTICE_S
            sample = self.client.receive_step(HELLO_REPEAT_S if starting else 0.25)
            if sample is None:
                if self.outputs.telemetry is not None:
                    self.outputs.telemetry.flush()  # nothing gathered waits on a plant that has stopped
                if time.monotonic() - last_heard > SILENCE_NOTICE_S:
                    counters.plant_silences += 1
                    self.note("the plant is silent; waiting for it")
                    last_heard = time.monotonic()
                self.client.hello()
                continue
            busy_from = time.perf_counter()
            last_heard = time.monotonic()
            self._plant_messages()
            if self.boot_usec is None or sample.time_usec < self.boot_usec:  # first step, or a new plant run
                self.boot_usec = sample.time_usec
            if not update_from_hil_state(self.state, sample.state, self.geodetic, self.airframe.gravity):
                counters.invalid_states += 1
                continue  # no answer: the plant holds the last command (and counts it)
            self.state.time_usec -= self.boot_usec
            t_usec = self.state.time_usec
            if self._start_usec is not None and t_usec < self._last_usec:
                self._restart(t_usec)
            self._last_usec = t_usec
            if self._start_usec is None:
                self._start_usec = t_usec
                if not self.commander.started:
                    self.commander.start(self.state)
            self.commander.observe(self.state)
            self._check_actuators()
            t = (t_usec - self._start_usec) / 1e6
            if self.offboard_lockstep and self.services is not None:
                self.services.hold(t_usec, lambda: self.commander.setpoints_cover(t_usec), self.should_stop)
            self.injection.inject_scheduled(t, t_usec)
            for failure in self.injection.tick(t_usec):
                self._learn(failure)
            if self.params.version != self._params_seen:
                self._parameters_changed()
            self.plant_parameters.step(t_usec)  # before this step's answer: the plant applies it to this step
            fixed = self._control(t_usec, t)
            if fixed is None:
                stepped = self.controller.step(self.state)
                if stepped or pwm is None or pwm is self._idle_pwm or pwm is self._disarmed_pwm:
                    pwm = command_to_pwm(self.airframe, self.controller.command)
            else:
                pwm = fixed
            self.client.send_pwm(sample.time_usec, pwm)
            counters.steps += 1
            if self.calibration is not None and self.calibration.running:
                euler = self.state.euler
                self.calibration.step(Reading(self._sensors(t_usec), float(euler[0]), float(euler[1]), t_usec))
            if self.outputs.ulog is not None:
                self.outputs.ulog.step(t_usec, self.state, self.controller, pwm)
            if self.services is not None:
                self.services.receive(t_usec)
                if self._status_due(t_usec):
                    self.services.publish(self._status(t_usec, sample, pwm))
                else:
                    self.services.flush()
            if self.outputs.log is not None:
                self.outputs.log.maybe_write(t, t_usec, self.state, self.controller)
            counters.busy_s += time.perf_counter() - busy_from
            # Half a plant step of tolerance: the plant rounds a duration to whole steps (2.5 ms) too.
            if self.duration_usec is not None and t_usec - self._start_usec >= self.duration_usec - 1250:
                break

    def summary(self) -> dict[str, Any]:
        c = self.counters
        sim_time = (self._last_usec - (self._start_usec or 0)) / 1e6 if c.steps else 0.0
        summary = {
            "steps": c.steps,
            "sim_time_s": sim_time,
            "wall_time_s": round(c.wall_s, 3),
            "real_time_factor": round(sim_time / c.wall_s, 2) if c.wall_s > 0 else None,
            "busy_us_per_step": round(c.busy_s / max(c.steps, 1) * 1e6, 1),
            "status_snapshots": c.status_snapshots,
            "invalid_states": c.invalid_states,
            "plant_silences": c.plant_silences,
            "dropped_from_plant": dict(self.client.link.dropped),
            "foreign_on_plant_link": self.client.foreign,
            "failures_acknowledged": self.injection.counters.acknowledged,
            "failures_refused": self.injection.counters.refused,
            "allocation_fallbacks": self.controller.allocation_fallbacks,
            "allocation_restarts": self.controller.allocator.restarts,
            "mode_switches": self.controller.mode_switches,
            "mode": self.controller.mode,
            "flight_mode": self.commander.mode,
            "armed": self.commander.armed,
            "controllers_started": self.controllers_started,
            "failsafes": self.commander.failsafes,
        }
        summary["controller"] = self.controller.controller_statistics()
        if self.services is not None:
            summary["links"] = self.services.summary() | {
                "setpoints_clamped": self.commander.setpoints_clamped,
                "mode": self.commander.mode,
                "armed": self.commander.armed,
            }
        return summary
