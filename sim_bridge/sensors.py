"""Synthesised sensors: the plant's MAVLink messages for one step (docs/plant-link.md, PX4 units).

HIL_STATE_QUATERNION is ground truth. HIL_SENSOR carries IMU (specific force, body rates), magnetometer
(gauss), barometer and differential pressure (hPa); HIL_GPS goes out at 10 Hz. Noise is off unless a seed is
given, so runs repeat exactly. A sensor failed OFF (MAV_CMD_INJECT_FAILURE, a FAILURE_UNIT_SENSOR_* unit) is
left out: its HIL_SENSOR fields are zero and their fields_updated bits clear, and a failed GPS sends no HIL_GPS;
HIL_STATE_QUATERNION stays the truth.
"""

from __future__ import annotations

import math

import numpy as np

from aircraft.failures import FailureUnit
from aircraft.frames import rotation_rows
from aircraft.rotors import RPM_PER_RAD_S
from sim_bridge.dynamics import ROTOR_SPEED
from sim_bridge.plant import DT_USEC, Plant
from transport.geodesy import LocalGeodetic
from transport.mavlink import Link, mavlink
from transport.mavlink_frames import HIL_GPS, HIL_SENSOR, HIL_STATE_QUATERNION, RAW_RPM

# Earth's field at the default home (Pittsburgh; WMM: 0.52 G, inclination 67 deg, declination -8.5 deg), NED.
MAG_FIELD_NED_GAUSS = (0.2008, -0.0300, 0.4787)
GPS_PERIOD_USEC = 100_000  # 10 Hz
ESC_PERIOD_USEC = 10_000  # 100 Hz: each rotor's ESC telemetry (RPM)
HEARTBEAT_PERIOD_USEC = 1_000_000
HIL_SENSOR_ALL_FIELDS = 0x1FFF  # acc xyz, gyro xyz, mag xyz, abs pressure, diff pressure, pressure alt, temperature
# HIL_SENSOR fields of each sensor: the fields_updated bits and the value indices (acc xyz, gyro xyz, mag xyz, abs
# pressure, diff pressure, pressure alt, temperature).
SENSOR_FIELDS = {
    FailureUnit.ACCEL: (0x007, (0, 1, 2)),
    FailureUnit.GYRO: (0x038, (3, 4, 5)),
    FailureUnit.MAG: (0x1C0, (6, 7, 8)),
    FailureUnit.BARO: (0x1A00, (9, 11, 12)),
    FailureUnit.AIRSPEED: (0x400, (10,)),
}
NOISE_STD = {"accel": 0.05, "gyro": 0.003, "mag": 0.002, "baro_hpa": 0.02, "diff_hpa": 0.01}


def isa_pressure_hpa(altitude_m: float) -> float:
    """Static pressure of the International Standard Atmosphere (troposphere), hPa."""
    return 1013.25 * (1.0 - 2.25577e-5 * altitude_m) ** 5.25588


def isa_temperature_c(altitude_m: float) -> float:
    return 15.0 - 0.0065 * altitude_m


class SensorSuite:
    """Builds the datagram the plant sends for its current state."""

    def __init__(self, plant: Plant, link: Link, geodetic: LocalGeodetic, noise_seed: int | None = None) -> None:
        self.plant = plant
        self.link = link
        self.geodetic = geodetic
        self.rng = None if noise_seed is None else np.random.default_rng(noise_seed)

    def datagram(self) -> bytes:
        """HIL_STATE_QUATERNION + HIL_SENSOR (+ HIL_GPS at 10 Hz, RAW_RPM per rotor at 100 Hz, HEARTBEAT at 1 Hz) for
        the current step.

        Per-step code: plain Python floats (one tolist() per array), since numpy scalars cost ~10x more.
        """
        plant = self.plant
        t = plant.time_usec
        (north, east, down, vn, ve, vd, qw, qx, qy, qz, p, q, r) = plant.state[0:13].tolist()
        ax, ay, az = plant.specific_force.tolist()
        airspeed = float(plant.airspeed[0])
        lat, lon, alt = self.geodetic.to_geodetic(north, east, down)
        lat_e7, lon_e7, alt_mm = int(round(lat * 1e7)), int(round(lon * 1e7)), int(round(alt * 1000))
        link = self.link
        mav = link.mav
        g0 = plant.airframe.gravity
        frames = [
            link.pack_fields(
                HIL_STATE_QUATERNION, t, (qw, qx, qy, qz), p, q, r, lat_e7, lon_e7, alt_mm,
                _clip_int16(vn * 100), _clip_int16(ve * 100), _clip_int16(vd * 100),
                _clip_uint16(airspeed * 100), _clip_uint16(airspeed * 100),
                _clip_int16(ax / g0 * 1000), _clip_int16(ay / g0 * 1000), _clip_int16(az / g0 * 1000),
            )
        ]  # fmt: skip
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = rotation_rows(qw, qx, qy, qz)
        bn, be, bd = MAG_FIELD_NED_GAUSS
        mx, my, mz = r00 * bn + r10 * be + r20 * bd, r01 * bn + r11 * be + r21 * bd, r02 * bn + r12 * be + r22 * bd
        baro = isa_pressure_hpa(alt)
        diff = 0.5 * plant.airframe.air_density * airspeed * airspeed / 100.0
        if self.rng is not None:
            n = self.rng.normal(0.0, 1.0, 11).tolist()
            ax, ay, az = ax + NOISE_STD["accel"] * n[0], ay + NOISE_STD["accel"] * n[1], az + NOISE_STD["accel"] * n[2]
            p, q, r = p + NOISE_STD["gyro"] * n[3], q + NOISE_STD["gyro"] * n[4], r + NOISE_STD["gyro"] * n[5]
            mx, my, mz = mx + NOISE_STD["mag"] * n[6], my + NOISE_STD["mag"] * n[7], mz + NOISE_STD["mag"] * n[8]
            baro, diff = baro + NOISE_STD["baro_hpa"] * n[9], diff + NOISE_STD["diff_hpa"] * n[10]
        values = [ax, ay, az, p, q, r, mx, my, mz, baro, diff, alt, isa_temperature_c(alt)]
        fields = silence(plant.failed_sensors, values) if plant.failed_sensors else HIL_SENSOR_ALL_FIELDS
        frames.append(link.pack_fields(HIL_SENSOR, t, *values, fields))
        if t % GPS_PERIOD_USEC == 0 and FailureUnit.GPS not in plant.failed_sensors:
            course = math.degrees(math.atan2(ve, vn)) % 360.0
            frames.append(
                link.pack_fields(
                    HIL_GPS, t, 3, lat_e7, lon_e7, alt_mm, 100, 100, _clip_uint16(math.hypot(vn, ve) * 100),
                    _clip_int16(vn * 100), _clip_int16(ve * 100), _clip_int16(vd * 100),
                    int(round(course * 100)) % 36000, 12,
                )
            )  # fmt: skip
        if t % ESC_PERIOD_USEC == 0:  # what the ESCs measure: the rotors' speed, a stopped one's too
            rotor_speeds = plant.state[ROTOR_SPEED].tolist()
            frames.extend(link.pack_fields(RAW_RPM, index, speed * RPM_PER_RAD_S)
                          for index, speed in enumerate(rotor_speeds))  # fmt: skip
        if t % HEARTBEAT_PERIOD_USEC == 0:
            frames.append(
                link.pack(
                    mav.heartbeat_encode(
                        mavlink.MAV_TYPE_GENERIC, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE
                    )
                )
            )
        return b"".join(frames)


def silence(failed: set[FailureUnit], values: list[float]) -> int:
    """Zero the HIL_SENSOR values of the failed sensors; the fields_updated bits of the others."""
    fields = HIL_SENSOR_ALL_FIELDS
    for unit in failed:
        bits, indices = SENSOR_FIELDS.get(unit, (0, ()))
        fields &= ~bits
        for index in indices:
            values[index] = 0.0
    return fields


def _clip_int16(value: float) -> int:
    return int(max(-32767, min(32767, round(value))))


def _clip_uint16(value: float) -> int:
    return int(max(0, min(65535, round(value))))


assert DT_USEC > 0 and GPS_PERIOD_USEC % DT_USEC == 0, "GPS period must be a whole number of steps"
assert ESC_PERIOD_USEC % DT_USEC == 0, "ESC telemetry period must be a whole number of steps"
