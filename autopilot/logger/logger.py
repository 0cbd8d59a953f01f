"""The logger, as PX4's: a ULog file a flight (docs/logs.md).

When (SDLOG_MODE, read at start as PX4 reads it at boot):
    0  from arming to disarming (the default)
    1  from the autopilot's first plant step until the first disarming, then as 0
    2  from the first plant step until the process ends

What: the topics of autopilot/logger/topics.py at PX4's default-profile intervals (simulated time), every STATUSTEXT
as a logged message ('L', sent to the logger by the MAVLink services' announcer), every parameter in the header
('P', and its default 'Q') and each change as it happens. Timestamps are the simulation time (us since the plant
started), PX4 SITL's clock; the file is named by the vehicle's clock (the wall clock at the first plant step, run
on by simulated time). Plant restarts (the clock going back) end the file: a ULog's timestamps must not go back.

The samples are encoded here, on the loop's thread, into a buffer handed to the file's writer thread about once a
simulated second (autopilot/logger/log_file.py): the loop never waits for the disk.
"""

from __future__ import annotations

import datetime as dt
import platform
import sys
import time
import zlib
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from enum import IntEnum
from pathlib import Path

from aircraft.actuators import TILTS
from autopilot.commander.commander import Commander
from autopilot.commander.failure_injection import FailureInjection
from autopilot.control.flight_controller import FlightController
from autopilot.logger import samples, ulog
from autopilot.logger.log_file import Chunk, LogFile
from autopilot.logger.topics import (
    ACTUATOR_MOTORS,
    ACTUATOR_OUTPUTS,
    ACTUATOR_SERVOS,
    BATTERY_STATUS,
    FAILURE_DETECTOR_STATUS,
    HOME_POSITION,
    MISSION_RESULT,
    ON_CHANGE,
    SENSOR_COMBINED,
    TILTROTOR_MPC_STATUS,
    TOPICS,
    TRAJECTORY_SETPOINT,
    VEHICLE_ATTITUDE,
    VEHICLE_ATTITUDE_SETPOINT,
    VEHICLE_GLOBAL_POSITION,
    VEHICLE_LOCAL_POSITION,
    VEHICLE_LOCAL_POSITION_SETPOINT,
    VEHICLE_RATES_SETPOINT,
    VEHICLE_STATUS,
    VTOL_VEHICLE_STATUS,
    Topic,
)
from autopilot.mpc.rti import MpcSolution
from autopilot.storage.mission_store import MissionStore
from autopilot.storage.parameters import INT32, ParameterStore
from autopilot.storage.vehicle_files import VehicleFiles
from autopilot.topics.flight_mode import ModeId
from autopilot.topics.home_position import HomePosition
from autopilot.topics.missions import Missions
from autopilot.topics.software_version import CUSTOM_VERSION, PX4_RELEASE
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.vehicle_status import vtol_state
from transport.geodesy import Home, LocalGeodetic
from transport.mavlink import mavlink as M

CHUNK_BYTES = 64 * 1024  # a chunk goes to the writer when this full,
CHUNK_PERIOD_USEC = 1_000_000  # or this old (so a log downloaded mid-flight, or cut by a kill, is recent)
STATUS_PERIOD_USEC = 500_000  # vehicle_status: at 2 Hz and on every change (PX4's commander)
# What is looked at 100 times a second (the commander's rate): vehicle_status, home, the mission's progress.
STATUS_CHECK = Topic("(status check)", 10_000, "")
PERIODIC = (*(topic for topic in TOPICS if topic.interval_usec != ON_CHANGE), STATUS_CHECK)
TEXT_BACKLOG = 16  # texts said just before a log starts (the arming's) are written at its start
TEXT_BACKLOG_USEC = 1_000_000
JOIN_TIMEOUT_S = 10.0


class LogMode(IntEnum):
    """SDLOG_MODE (PX4's 3, an RC switch, and 4 are not built)."""

    WHILE_ARMED = 0
    BOOT_UNTIL_DISARM = 1
    BOOT_UNTIL_SHUTDOWN = 2


@dataclass(frozen=True)
class VehicleIdentity:
    """What the logger states about the vehicle: its system id, the local frame's origin, its modes, its gravity
    (m/s^2) and the rotors' full thrust together (N), which normalises the thrust set-points."""

    system_id: int
    origin: Home
    modes: tuple[ModeId, ...]
    gravity: float
    thrust_max_total: float


class Logger:
    def __init__(self, files: VehicleFiles, params: ParameterStore, commander: Commander, missions: MissionStore,
                 injection: FailureInjection, vehicle: VehicleIdentity,
                 note: Callable[[str], None] = lambda text: print(f"vtol-autopilot: {text}", file=sys.stderr),
                 wall_clock: Callable[[], float] = time.time) -> None:  # fmt: skip
        self.files = files
        self.params = params
        self.commander = commander
        self.missions = missions
        self.injection = injection
        self.vehicle = vehicle
        self.note = note
        self.wall_clock = wall_clock
        self.mode = LogMode(params.get_int("SDLOG_MODE"))
        self.written: list[Path] = []  # the logs of this run, in order
        self.errors = 0
        self._geodetic = LocalGeodetic(vehicle.origin)
        self._rates_sp = samples.BodyRateSetpoint()
        self._valid_modes = samples.nav_states_mask(vehicle.modes)
        self._boot_phase = self.mode != LogMode.WHILE_ARMED
        self._was_armed = False
        self._ending = False  # no longer wanted: the log ends at the next step
        self._refused = False  # the file could not be created: no new try until logging is wanted again
        self._clock_origin: tuple[float, int] | None = None  # (wall seconds, simulated us) at the first step
        self._file: LogFile | None = None
        self._closed: list[LogFile] = []
        self._buffer = bytearray()
        self._chunk_first_usec = 0
        self._texts: deque[tuple[int, int, str]] = deque(maxlen=TEXT_BACKLOG)
        self._next: dict[str, int] = {}
        self._next_periodic_usec = 0
        self._prefixes = {topic.name: ulog.data_prefix(index, topic.packer.size) for index, topic in enumerate(TOPICS)}
        self._params_version = params.version
        self._params_logged: dict[str, float] = {}
        self._last_usec = 0
        self._home: HomePosition | None = None
        self._home_count = 0
        self._missions: Missions | None = None
        self._solution: MpcSolution | None = None
        self._status_key: tuple | None = None
        self._status_published_usec = 0
        self._armed_usec = 0
        self._takeoff_usec = 0
        self._flying = False
        self._nav: int | None = None
        self._nav_usec = 0

    # ---- when ---------------------------------------------------------------------------------------------------
    def step(self, t_usec: int, state: VehicleState, controller: FlightController, pwm: list[int]) -> None:
        """Once per plant step, after the controller's: start or stop the log, then the samples that are due."""
        if self._clock_origin is None:
            self._clock_origin = (self.wall_clock(), t_usec)
        armed = self.commander.armed
        if self.mode == LogMode.BOOT_UNTIL_DISARM and self._boot_phase and self._was_armed and not armed:
            self._boot_phase = False
        self._was_armed = armed
        wanted = armed or self._boot_phase
        if wanted:
            self._ending = False
            if self._file is None and not self._refused:
                self._start(t_usec)
        else:
            self._refused = False
        if not wanted and self._file is not None:
            if self._ending:  # a step later: the disarming's texts (said after this step's samples) are in
                self._stop()
            self._ending = True
        if self._file is not None:
            self._sample(t_usec, state, controller, pwm)

    def statustext(self, time_usec: int, severity: int, text: str) -> None:
        """A STATUSTEXT the vehicle said: a logged message ('L') in the log being written (or the next, if it starts
        within a second)."""
        if self._file is None:
            self._texts.append((time_usec, severity, text))
            return
        self._buffer += ulog.logged_string(severity, time_usec, text)

    def restart(self) -> None:
        """The plant's clock went back: end the log (its timestamps would go back); a new one starts if wanted."""
        if self._file is not None:
            self._stop()
        self._clock_origin = None
        self._texts.clear()

    def close(self) -> None:
        """The process ends: end the log and wait for every file to be written."""
        if self._file is not None:
            self._stop()
        for file in self._closed:
            if not file.join(JOIN_TIMEOUT_S):
                self.note(f"the log {file.path} was not finished within {JOIN_TIMEOUT_S:g} s")
        self._report_errors()

    def finishing(self) -> bool:
        """A log has ended and is still being written to disk."""
        return any(not file.finished for file in self._closed)

    @property
    def logging(self) -> Path | None:
        """The log being written, None between logs."""
        return None if self._file is None else self._file.path

    def summary(self) -> dict:
        return {"logs": [str(path) for path in self.written], "dropped_chunks": sum(f.dropped_chunks for f in
                self._closed + ([self._file] if self._file else [])), "errors": self.errors}  # fmt: skip

    # ---- the file -----------------------------------------------------------------------------------------------
    def _vehicle_utc(self, t_usec: int) -> dt.datetime:
        assert self._clock_origin is not None
        wall_s, first_usec = self._clock_origin
        return dt.datetime.fromtimestamp(wall_s + (t_usec - first_usec) / 1e6, dt.UTC)

    def _start(self, t_usec: int) -> None:
        path = self.files.new_log_path(self._vehicle_utc(t_usec))
        try:
            self._file = LogFile.create(path)
        except OSError as exc:
            self.errors += 1
            self.note(f"cannot create the log {path}: {exc.strerror or exc}; not logging")
            self._refused = True  # not tried again at every step: at the next arming
            return
        self.written.append(path)
        self._next = {topic.name: t_usec for topic in PERIODIC}
        self._next_periodic_usec = t_usec
        self._last_usec = self._chunk_first_usec = t_usec
        self._home = self._missions = self._solution = self._status_key = None
        self._buffer = bytearray(self._header(t_usec))
        while self._texts:
            time_usec, severity, text = self._texts.popleft()
            if t_usec - time_usec <= TEXT_BACKLOG_USEC:
                self._buffer += ulog.logged_string(severity, t_usec, text)

    def _header(self, t_usec: int) -> bytes:
        v = self.vehicle
        parts = [ulog.file_header(t_usec), ulog.flag_bits(), ulog.info_string("sys_name", "tiltrotor-sitl"),
                 ulog.info_string("ver_hw", "TILTROTOR_SITL"), ulog.info_string("ver_sw", CUSTOM_VERSION.decode()),
                 ulog.info_uint32("ver_sw_release", PX4_RELEASE),
                 ulog.info_string("sys_os_name", platform.system() or "unknown"),
                 ulog.info_string("sys_toolchain", platform.python_implementation()),
                 ulog.info_string("sys_toolchain_ver", platform.python_version()),
                 ulog.info_string("sys_uuid", f"tiltrotor-sitl-{v.system_id}"), ulog.info_int32("time_ref_utc", 0)]  # fmt: skip
        parts += [ulog.format_definition(topic.name, topic.fields) for topic in TOPICS]
        self._params_logged = dict(self.params.values)
        self._params_version = self.params.version
        for definition in self.params.definitions:
            integer = definition.kind == INT32
            parts.append(ulog.parameter(definition.name, self.params[definition.name], integer))
            parts.append(ulog.parameter_default(definition.name, definition.default, integer))
        parts += [ulog.subscription(index, topic.name) for index, topic in enumerate(TOPICS)]
        return b"".join(parts)

    def _stop(self) -> None:
        assert self._file is not None
        self._submit()
        self._file.close()
        self._closed.append(self._file)
        self._file = None
        self._report_errors()

    def _submit(self) -> None:
        if self._file is not None and self._buffer:
            self._file.submit(Chunk(bytes(self._buffer), self._chunk_first_usec, self._last_usec))
        self._buffer = bytearray()
        self._chunk_first_usec = self._last_usec

    def _report_errors(self) -> None:
        for file in self._closed:
            if file.error is not None:
                self.errors += 1
                self.note(file.error)
                file.error = None

    # ---- what ---------------------------------------------------------------------------------------------------
    def _due(self, topic: Topic, t_usec: int) -> bool:
        if t_usec < self._next[topic.name]:
            return False
        self._next[topic.name] = t_usec + topic.interval_usec
        return True

    def _write(self, topic: Topic, values: tuple) -> None:
        self._buffer += self._prefixes[topic.name] + topic.packer.pack(*values)

    def _sample(self, t: int, state: VehicleState, controller: FlightController, pwm: list[int]) -> None:
        """The samples due at t. Most plant steps have none due but the MPC's solve: the periodic topics are looked
        at only from the earliest time one of them is due."""
        self._last_usec = t
        if t >= self._next_periodic_usec:
            self._periodic(t, state, controller, pwm)
            self._next_periodic_usec = min(self._next.values())  # _next holds the PERIODIC topics (_start)
        mpc = controller.mpc
        solution = None if mpc is None else mpc.last_solution
        if solution is not self._solution and isinstance(solution, MpcSolution):
            self._solution = solution
            self._write(TILTROTOR_MPC_STATUS, samples.mpc_status(
                t, solution.solve_time_s * 1e3, solution.iterations, solution.cost, solution.ok,
                controller.fell_back_to_pid, solution.status))  # fmt: skip
        if t - self._chunk_first_usec >= CHUNK_PERIOD_USEC or len(self._buffer) >= CHUNK_BYTES:
            self._buffer += ulog.sync()
            self._submit()

    def _periodic(self, t: int, state: VehicleState, controller: FlightController, pwm: list[int]) -> None:
        if self.params.version != self._params_version:
            self._parameters_changed()
        command = controller.velocity_command
        yaw = controller.yaw_reference
        due = self._due
        if due(SENSOR_COMBINED, t):
            self._write(SENSOR_COMBINED, samples.sensor_combined(t, state))
        if due(VEHICLE_ATTITUDE, t):
            self._write(VEHICLE_ATTITUDE, samples.vehicle_attitude(t, state))
        thrust_body = None
        if due(VEHICLE_ATTITUDE_SETPOINT, t):
            thrust_body = samples.normalised_thrust(command.force_sp_body, self.vehicle.thrust_max_total)
            self._write(
                VEHICLE_ATTITUDE_SETPOINT, samples.vehicle_attitude_setpoint(t, command.euler_sp, thrust_body, yaw)
            )
        if due(VEHICLE_RATES_SETPOINT, t):
            thrust_body = thrust_body or samples.normalised_thrust(command.force_sp_body, self.vehicle.thrust_max_total)
            rates = self._rates_sp(state.euler, command.euler_sp, controller.attitude_gains)
            self._write(VEHICLE_RATES_SETPOINT, samples.vehicle_rates_setpoint(t, rates, thrust_body))
        if due(VEHICLE_LOCAL_POSITION, t):
            acceleration = samples.acceleration_ned(state, self.vehicle.gravity)
            self._write(VEHICLE_LOCAL_POSITION, samples.vehicle_local_position(
                t, state, acceleration, self.vehicle.origin, self._clock_origin[1] if self._clock_origin else t))  # fmt: skip
        if due(VEHICLE_LOCAL_POSITION_SETPOINT, t):
            force_ned = state.rotation() @ command.force_sp_body / self.vehicle.thrust_max_total
            self._write(VEHICLE_LOCAL_POSITION_SETPOINT, samples.vehicle_local_position_setpoint(
                t, controller.velocity_setpoint, tuple(force_ned.tolist()), command.euler_sp, yaw))  # fmt: skip
        if due(TRAJECTORY_SETPOINT, t):
            self._write(TRAJECTORY_SETPOINT, samples.trajectory_setpoint(t, controller.velocity_setpoint, yaw))
        if due(VEHICLE_GLOBAL_POSITION, t):
            self._write(VEHICLE_GLOBAL_POSITION, samples.vehicle_global_position(t, state, self._geodetic))
        mav_vtol = None
        if due(STATUS_CHECK, t):
            mav_vtol = vtol_state(controller.servos.tilt, controller.command[TILTS])
            self._vehicle_status(t, mav_vtol)
            self._on_change(t)
        if due(VTOL_VEHICLE_STATUS, t):
            mav_vtol = mav_vtol or vtol_state(controller.servos.tilt, controller.command[TILTS])
            self._write(VTOL_VEHICLE_STATUS, samples.vtol_vehicle_status(t, mav_vtol))
        if due(ACTUATOR_MOTORS, t):
            self._write(ACTUATOR_MOTORS, samples.actuator_motors(t, pwm))
        if due(ACTUATOR_SERVOS, t):
            self._write(ACTUATOR_SERVOS, samples.actuator_servos(t, pwm))
        if due(ACTUATOR_OUTPUTS, t):
            self._write(ACTUATOR_OUTPUTS, samples.actuator_outputs(t, pwm))
        if due(BATTERY_STATUS, t):
            self._write(BATTERY_STATUS, samples.battery_status(t))
        if due(FAILURE_DETECTOR_STATUS, t):
            mask = samples.motor_failure_mask(self.injection.known)
            self._write(FAILURE_DETECTOR_STATUS, samples.failure_detector_status(t, mask))

    def _vehicle_status(self, t: int, mav_vtol: int) -> None:
        c = self.commander
        if c.armed and not self._armed_usec:
            self._armed_usec = t
        elif not c.armed:
            self._armed_usec = 0
        if c.flying and not self._flying:
            self._takeoff_usec = t
        self._flying = c.flying
        nav = samples.nav_state(c.mode_id, c.terminated)
        if nav != self._nav:
            self._nav, self._nav_usec = nav, t
        transition = (
            mav_vtol if mav_vtol in (M.MAV_VTOL_STATE_TRANSITION_TO_FW, M.MAV_VTOL_STATE_TRANSITION_TO_MC) else 0
        )
        key = (c.armed, nav, mav_vtol == M.MAV_VTOL_STATE_FW, transition, c.started)
        if key == self._status_key and t - self._status_published_usec < STATUS_PERIOD_USEC:
            return
        self._status_key = key
        self._status_published_usec = t
        self._write(VEHICLE_STATUS, samples.vehicle_status(
            t, armed=c.armed, armed_usec=self._armed_usec, takeoff_usec=self._takeoff_usec, nav=nav,
            nav_usec=self._nav_usec, valid_modes=self._valid_modes, fixed_wing=key[2], transition=transition,
            failsafe=False, datalink_lost=False, system_id=self.vehicle.system_id, started=c.started))  # fmt: skip

    def _on_change(self, t: int) -> None:
        """The topics published when they change (looked at 100 times a second): home, the mission's progress."""
        home = self.commander.home
        if home is not self._home:
            self._home = home
            self._home_count += 1
            self._write(HOME_POSITION, samples.home_position(t, home, self._home_count))
        missions = self.missions.snapshot
        if missions is not self._missions:
            self._missions = missions
            mission_id = zlib.crc32(repr(missions.mission).encode())
            fence_id = zlib.crc32(repr(missions.fence).encode())
            self._write(MISSION_RESULT, samples.mission_result(t, missions, mission_id, fence_id, self._home_count))

    def _parameters_changed(self) -> None:
        """Each changed parameter as a 'P' in the data section, as PX4's logger writes a change."""
        self._params_version = self.params.version
        for definition in self.params.definitions:
            value = self.params[definition.name]
            if self._params_logged.get(definition.name) != value:
                self._params_logged[definition.name] = value
                self._buffer += ulog.parameter(definition.name, value, definition.kind == INT32)
