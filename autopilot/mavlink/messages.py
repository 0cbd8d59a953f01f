"""The telemetry messages, each built from the VehicleStatus snapshot alone (as PX4's mavlink streams read
vehicle_status and its topics), for the streams and for MAV_CMD_REQUEST_MESSAGE."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

from aircraft.failures import FailureUnit, failed_sensors
from autopilot.mavlink.component_metadata import MAVLINK_MSG_ID_COMPONENT_METADATA, component_metadata
from autopilot.topics.battery import BatteryStatus, BatteryWarning
from autopilot.topics.flight_mode import PX4_AUTO_MISSION, PX4_MAIN_AUTO
from autopilot.topics.home_position import HomePosition
from autopilot.topics.software_version import CUSTOM_VERSION as CUSTOM_VERSION_TAG
from autopilot.topics.software_version import PX4_RELEASE
from autopilot.topics.vehicle_status import VehicleStatus
from transport.mavlink import mavlink as M

SENSORS = (
    M.MAV_SYS_STATUS_SENSOR_3D_GYRO | M.MAV_SYS_STATUS_SENSOR_3D_ACCEL | M.MAV_SYS_STATUS_SENSOR_3D_MAG
    | M.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE | M.MAV_SYS_STATUS_SENSOR_DIFFERENTIAL_PRESSURE
    | M.MAV_SYS_STATUS_SENSOR_GPS | M.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL
    | M.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION | M.MAV_SYS_STATUS_SENSOR_YAW_POSITION
    | M.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL | M.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
    | M.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS | M.MAV_SYS_STATUS_AHRS | M.MAV_SYS_STATUS_SENSOR_BATTERY
    | M.MAV_SYS_STATUS_PREARM_CHECK
)  # fmt: skip
SENSOR_BITS = {  # a sensor failed OFF clears its health bit (present and enabled stay set, as PX4 reports it)
    FailureUnit.GYRO: M.MAV_SYS_STATUS_SENSOR_3D_GYRO, FailureUnit.ACCEL: M.MAV_SYS_STATUS_SENSOR_3D_ACCEL,
    FailureUnit.MAG: M.MAV_SYS_STATUS_SENSOR_3D_MAG, FailureUnit.BARO: M.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE,
    FailureUnit.AIRSPEED: M.MAV_SYS_STATUS_SENSOR_DIFFERENTIAL_PRESSURE, FailureUnit.GPS: M.MAV_SYS_STATUS_SENSOR_GPS,
}  # fmt: skip
CAPABILITIES = (
    M.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE | M.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    | M.MAV_PROTOCOL_CAPABILITY_COMMAND_INT | M.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
    | M.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
    # the mission protocol with MISSION_ITEM_INT, for missions, fences and rally points (MAVSDK refuses to upload
    # without MISSION_INT)
    | M.MAV_PROTOCOL_CAPABILITY_MISSION_INT | M.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
    | M.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
    # MAVLink FTP: the vehicle's files and its component metadata (docs/logs.md)
    | M.MAV_PROTOCOL_CAPABILITY_FTP
)  # fmt: skip
# The PX4 protocol level this vehicle behaves like (QGroundControl checks it); ours is in flight_custom_version.
PX4_VERSION = PX4_RELEASE  # 1.15.0 release
CUSTOM_VERSION = list(CUSTOM_VERSION_TAG)
CHARGE_STATES = {BatteryWarning.NONE: M.MAV_BATTERY_CHARGE_STATE_OK, BatteryWarning.LOW: M.MAV_BATTERY_CHARGE_STATE_LOW,
                 BatteryWarning.CRITICAL: M.MAV_BATTERY_CHARGE_STATE_CRITICAL,
                 BatteryWarning.EMERGENCY: M.MAV_BATTERY_CHARGE_STATE_EMERGENCY}  # fmt: skip
NO_CELL = 0xFFFF  # BATTERY_STATUS: a cell voltage not sent
BASE_MODE = (M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | M.MAV_MODE_FLAG_STABILIZE_ENABLED | M.MAV_MODE_FLAG_GUIDED_ENABLED
             | M.MAV_MODE_FLAG_AUTO_ENABLED)  # fmt: skip


def heading_cdeg(status: VehicleStatus) -> int:
    return int(round(math.degrees(float(status.estimate.euler[2])) * 100)) % 36000


def heartbeat(mav: Any, status: VehicleStatus) -> Any:
    base = BASE_MODE | (M.MAV_MODE_FLAG_SAFETY_ARMED if status.armed else 0)
    state = M.MAV_STATE_ACTIVE if status.armed else M.MAV_STATE_STANDBY
    if not status.started:
        state = M.MAV_STATE_BOOT
    elif status.terminated:
        state = M.MAV_STATE_FLIGHT_TERMINATION
    return mav.heartbeat_encode(M.MAV_TYPE_VTOL_TILTROTOR, M.MAV_AUTOPILOT_PX4, base, status.mode.custom_mode, state)


def sys_status(mav: Any, status: VehicleStatus) -> Any:
    health = SENSORS if status.started else SENSORS & ~M.MAV_SYS_STATUS_PREARM_CHECK
    for unit in failed_sensors(status.failures):
        health &= ~SENSOR_BITS[unit]
    if status.motors_failed or status.servos_jammed:  # as PX4's health report of motors_escs (actuators here)
        health &= ~M.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
    battery = status.battery
    return mav.sys_status_encode(SENSORS, SENSORS, health, 0, int(round(battery.voltage_v * 1000)), -1,
                                 percent(battery), 0, 0, 0, 0, 0, 0)  # fmt: skip


def extended_sys_state(mav: Any, status: VehicleStatus) -> Any:
    return mav.extended_sys_state_encode(status.vtol_state, status.landed_state)


def attitude(mav: Any, status: VehicleStatus) -> Any:
    roll, pitch, yaw = status.estimate.euler.tolist()
    p, q, r = status.estimate.body_rates.tolist()
    return mav.attitude_encode(status.time_boot_ms, roll, pitch, yaw, p, q, r)


def attitude_quaternion(mav: Any, status: VehicleStatus) -> Any:
    w, x, y, z = status.estimate.quaternion.tolist()
    p, q, r = status.estimate.body_rates.tolist()
    return mav.attitude_quaternion_encode(status.time_boot_ms, w, x, y, z, p, q, r)


def local_position(mav: Any, status: VehicleStatus) -> Any:
    x, y, z = status.estimate.position_ned.tolist()
    vx, vy, vz = status.estimate.velocity_ned.tolist()
    return mav.local_position_ned_encode(status.time_boot_ms, x, y, z, vx, vy, vz)


def global_position(mav: Any, status: VehicleStatus) -> Any:
    g = status.position
    relative_mm = int(round((status.home.down - float(status.estimate.position_ned[2])) * 1000))  # above home (PX4)
    return mav.global_position_int_encode(status.time_boot_ms, g.lat_e7, g.lon_e7, g.alt_mm, relative_mm, g.vn_cms,
                                          g.ve_cms, g.vd_cms, heading_cdeg(status))  # fmt: skip


def gps_raw(mav: Any, status: VehicleStatus) -> Any:
    g = status.position
    vn, ve = float(status.estimate.velocity_ned[0]), float(status.estimate.velocity_ned[1])
    cog = int(round(math.degrees(math.atan2(ve, vn)) * 100)) % 36000 if math.hypot(vn, ve) > 0.1 else 65535
    if FailureUnit.GPS in failed_sensors(status.failures):  # PX4 reports the GPS it no longer hears as no fix
        return mav.gps_raw_int_encode(status.time_usec, M.GPS_FIX_TYPE_NO_FIX, 0, 0, 0, 65535, 65535, 65535, 65535, 0)
    return mav.gps_raw_int_encode(status.time_usec, M.GPS_FIX_TYPE_3D_FIX, g.lat_e7, g.lon_e7, g.alt_mm, 70, 100,
                                  int(round(math.hypot(vn, ve) * 100)), cog, 12)  # fmt: skip


def vfr_hud(mav: Any, status: VehicleStatus) -> Any:
    s = status.estimate
    return mav.vfr_hud_encode(
        s.airspeed,
        math.hypot(s.velocity_ned[0], s.velocity_ned[1]),
        heading_cdeg(status) // 100,
        status.throttle_percent,
        status.position.alt_mm / 1000.0,
        -float(s.velocity_ned[2]),
    )


def servo_output(mav: Any, status: VehicleStatus) -> Any:
    return mav.servo_output_raw_encode(status.time_usec & 0xFFFFFFFF, 0, *status.pwm)


def percent(battery: BatteryStatus) -> int:
    """The state of charge in whole percent, as SYS_STATUS and BATTERY_STATUS carry it."""
    return int(round(battery.remaining * 100))


def battery(mav: Any, status: VehicleStatus) -> Any:
    """BATTERY_STATUS as PX4 sends its simulated battery's: each cell's voltage, no current (-1), the charge, the
    charge state from the warning level."""
    b = status.battery
    cells = [int(round(b.cell_voltage_v * 1000))] * b.cell_count + [NO_CELL] * (10 - b.cell_count)
    return mav.battery_status_encode(0, M.MAV_BATTERY_FUNCTION_ALL, M.MAV_BATTERY_TYPE_LIPO, 32767, cells, -1, -1, -1,
                                     percent(b), 0, CHARGE_STATES[b.warning])  # fmt: skip


def home_position(mav: Any, home: HomePosition, time_usec: int) -> Any:
    """HOME_POSITION: home's latitude, longitude, altitude and its place in the local frame (x, y, z)."""
    return mav.home_position_encode(int(round(home.lat * 1e7)), int(round(home.lon * 1e7)),
                                    int(round(home.alt * 1000)), home.north, home.east, home.down,
                                    [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0, time_usec)  # fmt: skip


def system_time(mav: Any, time_usec: int) -> Any:
    """SYSTEM_TIME: the wall clock, and time_boot_ms = the simulation time (the lockstep client reads it)."""
    return mav.system_time_encode(int(time.time() * 1e6), (time_usec // 1000) & 0xFFFFFFFF)


def autopilot_version(mav: Any) -> Any:
    return mav.autopilot_version_encode(CAPABILITIES, PX4_VERSION, 0, 0, 0, CUSTOM_VERSION, [0] * 8, [0] * 8, 0, 0,
                                        0x5452_5300 + mav.srcSystem)  # fmt: skip


def mission_current(mav: Any, status: VehicleStatus) -> Any:
    """MISSION_CURRENT as PX4 fills it: total UINT16_MAX without a mission, mission_mode 1 in Mission mode else 2."""
    m = status.missions
    total = len(m.mission) if m.mission else 0xFFFF
    return mav.mission_current_encode(
        m.current, total, m.state, 1 if (status.mode.main, status.mode.sub) == (PX4_MAIN_AUTO, PX4_AUTO_MISSION) else 2
    )


def highres_imu(mav: Any, status: VehicleStatus) -> Any | None:
    """HIGHRES_IMU from the simulated sensors, calibrated (None before the plant sent any)."""
    s = status.sensors
    if s is None:
        return None
    return mav.highres_imu_encode(status.time_usec, *s.accel, *s.gyro, *s.mag, s.abs_pressure, s.diff_pressure,
                                  s.pressure_alt, s.temperature, s.fields_updated & 0xFFFF, 0)  # fmt: skip


BUILDERS: dict[int, Callable[[Any, VehicleStatus], Any]] = {
    M.MAVLINK_MSG_ID_HIGHRES_IMU: highres_imu,
    M.MAVLINK_MSG_ID_HEARTBEAT: heartbeat,
    M.MAVLINK_MSG_ID_SYS_STATUS: sys_status,
    M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: extended_sys_state,
    M.MAVLINK_MSG_ID_ATTITUDE: attitude,
    M.MAVLINK_MSG_ID_ATTITUDE_QUATERNION: attitude_quaternion,
    M.MAVLINK_MSG_ID_LOCAL_POSITION_NED: local_position,
    M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: global_position,
    M.MAVLINK_MSG_ID_VFR_HUD: vfr_hud,
    M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: servo_output,
    M.MAVLINK_MSG_ID_GPS_RAW_INT: gps_raw,
    M.MAVLINK_MSG_ID_BATTERY_STATUS: battery,
    M.MAVLINK_MSG_ID_SYSTEM_TIME: lambda mav, status: system_time(mav, status.time_usec),
    M.MAVLINK_MSG_ID_AUTOPILOT_VERSION: lambda mav, status: autopilot_version(mav),
    M.MAVLINK_MSG_ID_MISSION_CURRENT: mission_current,
    M.MAVLINK_MSG_ID_HOME_POSITION: lambda mav, status: home_position(mav, status.home, status.time_usec),
    MAVLINK_MSG_ID_COMPONENT_METADATA: component_metadata,
}


def build(msgid: int, mav: Any, status: VehicleStatus) -> Any | None:
    """Message `msgid` now, or None if this vehicle has no such message."""
    builder = BUILDERS.get(msgid)
    return None if builder is None else builder(mav, status)
