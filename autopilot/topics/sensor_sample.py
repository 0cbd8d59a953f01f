"""The simulated sensors of one plant step, as the plant's HIL_SENSOR gives them (PX4's sensor_combined with the
magnetometer and barometers): what HIGHRES_IMU reports and the calibrations measure."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any


@dataclass(frozen=True, slots=True)
class SensorSample:
    time_usec: int  # the autopilot's clock (since boot)
    accel: tuple[float, float, float]  # m/s², body FRD (specific force)
    gyro: tuple[float, float, float]  # rad/s, body FRD
    mag: tuple[float, float, float]  # gauss, body FRD
    abs_pressure: float  # hPa
    diff_pressure: float  # hPa
    pressure_alt: float  # m
    temperature: float  # °C
    fields_updated: int  # HIL_SENSOR's bits: a sensor failed OFF has its bits clear


def sensor_sample(hil_sensor: Any, time_usec: int) -> SensorSample:
    """A SensorSample of a HIL_SENSOR message, stamped with the autopilot's time."""
    m = hil_sensor
    return SensorSample(time_usec, (m.xacc, m.yacc, m.zacc), (m.xgyro, m.ygyro, m.zgyro), (m.xmag, m.ymag, m.zmag),
                        m.abs_pressure, m.diff_pressure, m.pressure_alt, m.temperature, m.fields_updated)  # fmt: skip


def calibrated(sample: SensorSample, gyro_offsets: tuple[float, float, float]) -> SensorSample:
    """The sample with the gyro calibration's offsets (CAL_GYRO0_X/Y/ZOFF) taken off, as PX4 corrects its sensors."""
    gyro = (sample.gyro[0] - gyro_offsets[0], sample.gyro[1] - gyro_offsets[1], sample.gyro[2] - gyro_offsets[2])
    return replace(sample, gyro=gyro)
