"""Sensor calibration (MAV_CMD_PREFLIGHT_CALIBRATION) as PX4's commander runs it, in simulated time, speaking PX4's
`[cal]` STATUSTEXT protocol, which QGroundControl's sensor page and MAVSDK's calibration plugin follow
(docs/mavlink.md#calibration).

Gyro and level horizon measure the simulated vehicle standing still and store PX4's parameters (CAL_GYRO0_*OFF,
SENS_BOARD_X/Y_OFF). Accelerometer and magnetometer calibrations ask for the vehicle to be turned onto each of its
six sides; nothing turns a simulated vehicle by hand, so, as in PX4's SITL, the side it stands on is measured, the
same side is found again, and the calibration fails with "timeout: no motion".

Each routine is a generator fed one `Reading` per plant step; it says what it does through `say`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Generator
from dataclasses import dataclass
from enum import Enum

import numpy as np

from autopilot.storage.parameters import ParameterStore
from autopilot.topics.requests import Reply
from autopilot.topics.sensor_sample import SensorSample
from transport.mavlink import mavlink

STARTED = "[cal] calibration started: 2 {}"  # PX4's calibration_messages.h (QGroundControl parses these texts)
DONE = "[cal] calibration done: {}"
FAILED = "[cal] calibration failed: {}"
CANCELLED = "[cal] calibration cancelled"
PROGRESS = "[cal] progress <{}>"

GYRO_SAMPLING_USEC = 1_000_000
LEVEL_SAMPLING_USEC = 2_000_000
STILL_USEC = 1_000_000  # an orientation is detected after the vehicle has stood this long on it
SIDE_SAMPLING_USEC = 1_000_000
MOTION_RAD_S = 0.2  # a gyro sample this far from the first one: the vehicle moved
LEVEL_TILT_MAX_DEG = 10.0  # PX4 refuses a level calibration on a slope steeper than this
ORIENTATION_FAILURES = 4  # beyond this many failed detections: "timeout: no motion" (PX4's)
GYRO_BITS = 0b111000  # HIL_SENSOR fields_updated: xgyro, ygyro, zgyro
SIDES = ("back", "front", "left", "right", "up", "down")  # PX4's detect_orientation names, in its order


class Sensor(Enum):
    GYRO = "gyro"
    LEVEL = "level"
    ACCEL = "accel"
    MAG = "mag"


@dataclass(frozen=True)
class Reading:
    """One plant step as a calibration sees it: the sensors (None before the plant sent any) and the attitude."""

    sample: SensorSample | None
    roll: float  # rad
    pitch: float  # rad
    time_usec: int


Say = Callable[[int, str], None]
Routine = Generator[None, Reading, None]


def side_of(accel: tuple[float, float, float]) -> str:
    """The side the vehicle stands on, from the specific force (body FRD): level on its wheels is "down"."""
    axis = int(np.argmax(np.abs(accel)))
    return SIDES[2 * axis + (1 if accel[axis] < 0 else 0)]


class Calibration:
    """The one calibration that may run at a time."""

    def __init__(self, params: ParameterStore, say: Say) -> None:
        self.params = params
        self.say = say
        self._routine: Routine | None = None

    @property
    def running(self) -> bool:
        return self._routine is not None

    def start(self, sensor: Sensor) -> Reply:
        if self._routine is not None:
            return mavlink.MAV_RESULT_TEMPORARILY_REJECTED, "Calibration denied: one is already running"
        routines = {Sensor.GYRO: self._gyro, Sensor.LEVEL: self._level, Sensor.ACCEL: self._orientations,
                    Sensor.MAG: self._orientations}  # fmt: skip
        self.say(mavlink.MAV_SEVERITY_INFO, STARTED.format(sensor.value))
        self._routine = routines[sensor](sensor)
        next(self._routine)
        return mavlink.MAV_RESULT_ACCEPTED, None

    def cancel(self) -> Reply:
        """PREFLIGHT_CALIBRATION with every param 0: stop the running calibration (ACCEPTED either way, as PX4)."""
        if self._routine is not None:
            self._routine.close()
            self._routine = None
            self.say(mavlink.MAV_SEVERITY_CRITICAL, CANCELLED)
        return mavlink.MAV_RESULT_ACCEPTED, None

    def step(self, reading: Reading) -> None:
        """Feed the running calibration one plant step."""
        if self._routine is None:
            return
        try:
            self._routine.send(reading)
        except StopIteration:
            self._routine = None

    # ---- the routines ----------------------------------------------------------------------------------------
    def _progress(self, percent: int) -> None:
        self.say(mavlink.MAV_SEVERITY_INFO, PROGRESS.format(percent))

    def _failed(self, why: str) -> None:
        self.say(mavlink.MAV_SEVERITY_CRITICAL, FAILED.format(why))

    def _gyro(self, sensor: Sensor) -> Routine:
        """The mean rate of a vehicle standing still is the gyro's offset (CAL_GYRO0_X/Y/ZOFF)."""
        reading = yield
        samples: list[tuple[float, float, float]] = []
        start, said = reading.time_usec, 0
        while reading.time_usec - start < GYRO_SAMPLING_USEC:
            sample = reading.sample
            if sample is None or sample.fields_updated & GYRO_BITS != GYRO_BITS:
                self._failed("reading sensor")
                return
            if samples and max(abs(a - b) for a, b in zip(sample.gyro, samples[0], strict=True)) > MOTION_RAD_S:
                self._failed("motion, hold still")
                return
            samples.append(sample.gyro)
            percent = min(100, (reading.time_usec - start) * 100 // GYRO_SAMPLING_USEC) // 10 * 10
            if percent > said:
                said = percent
                self._progress(percent)
            reading = yield
        offsets = np.mean(np.array(samples), axis=0)
        for axis, offset in zip("XYZ", offsets.tolist(), strict=True):
            self.params.set(f"CAL_GYRO0_{axis}OFF", float(np.float32(offset)))
        self._progress(100)
        self.say(mavlink.MAV_SEVERITY_INFO, DONE.format(sensor.value))

    def _level(self, sensor: Sensor) -> Routine:
        """The mean roll and pitch of the vehicle standing level are the board's offsets (SENS_BOARD_X/Y_OFF)."""
        reading = yield
        rolls, pitches = [], []
        start, said = reading.time_usec, 0
        while reading.time_usec - start < LEVEL_SAMPLING_USEC:
            rolls.append(reading.roll)
            pitches.append(reading.pitch)
            percent = min(100, (reading.time_usec - start) * 100 // LEVEL_SAMPLING_USEC) // 10 * 10
            if percent > said:
                said = percent
                self._progress(percent)
            reading = yield
        roll, pitch = math.degrees(float(np.mean(rolls))), math.degrees(float(np.mean(pitches)))
        if max(abs(roll), abs(pitch)) > LEVEL_TILT_MAX_DEG:
            self._failed(f"level: tilted {roll:.1f}/{pitch:.1f} deg, more than {LEVEL_TILT_MAX_DEG:g}")
            return
        self.params.set("SENS_BOARD_X_OFF", float(np.float32(roll)))
        self.params.set("SENS_BOARD_Y_OFF", float(np.float32(pitch)))
        self._progress(100)
        self.say(mavlink.MAV_SEVERITY_INFO, DONE.format(sensor.value))

    def _orientations(self, sensor: Sensor) -> Routine:
        """PX4's six-side protocol: each round lists the sides pending, waits for the vehicle to stand still on one,
        measures it; a side already done, or motion, is a failure, and more than ORIENTATION_FAILURES of them in a
        row end it."""
        reading = yield
        done: list[str] = []
        failures = 0
        while failures <= ORIENTATION_FAILURES:
            pending = " ".join(side for side in SIDES if side not in done)
            self.say(mavlink.MAV_SEVERITY_INFO, f"[cal] pending: {pending}")
            self.say(mavlink.MAV_SEVERITY_INFO, "[cal] hold vehicle still on a pending side")
            start = reading.time_usec
            while reading.time_usec - start < STILL_USEC:
                reading = yield
            if reading.sample is None:
                self._failed("reading sensor")
                return
            side = side_of(reading.sample.accel)
            if side in done:
                failures += 1
                self.say(mavlink.MAV_SEVERITY_INFO, f"[cal] {side} side already completed")
                continue
            failures = 0
            self.say(mavlink.MAV_SEVERITY_INFO, f"[cal] {side} orientation detected")
            start = reading.time_usec
            while reading.time_usec - start < SIDE_SAMPLING_USEC:
                reading = yield
            done.append(side)
            self.say(mavlink.MAV_SEVERITY_INFO, f"[cal] {side} side done, rotate to a different side")
            self._progress(len(done) * 100 // len(SIDES))
        self._failed("timeout: no motion")
