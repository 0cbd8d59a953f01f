"""The logged topics: PX4's uORB messages with their names and fields (PX4 v1.15's msg/*.msg, in their order), at
the intervals of PX4's default logger profile (its logger's add_default_topics()), and one topic of ours.

A topic's fields are written in ULog's own syntax ("uint64_t timestamp;float[4] q;..."), which is also its 'F'
message; the samples (autopilot/logger/samples.py) are flat tuples in that order, arrays spread out.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

from autopilot.logger.ulog import TYPE_CODES

ON_CHANGE = 0  # interval 0: every publication (PX4's add_topic without an interval)
# sensor_combined is logged at every publication, which PX4 makes at its IMU integration rate (IMU_INTEG_RATE,
# 200 Hz by default): every other plant step here.
IMU_INTERVAL_USEC = 5_000


@dataclass(frozen=True)
class Topic:
    name: str
    interval_usec: int  # at most one sample this often (ON_CHANGE: each publication)
    fields: str  # "type name;type name;..." (ULog field syntax)
    packer: struct.Struct = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "packer", struct.Struct("<" + "".join(_codes(self.fields))))

    def pack(self, values: tuple) -> bytes:
        return self.packer.pack(*values)

    @property
    def field_names(self) -> list[str]:
        return [item.split(" ")[1] for item in self.fields.split(";") if item]


def _codes(fields: str) -> list[str]:
    """The struct codes of a field list, arrays as counts ("float[4] q" -> "4f"; "char[16] s" -> "16s")."""
    codes = []
    for item in fields.split(";"):
        if not item:
            continue
        kind, _ = item.split(" ")
        count = 1
        if "[" in kind:
            kind, _, size = kind.partition("[")
            count = int(size.rstrip("]"))
        code = TYPE_CODES[kind]
        codes.append(f"{count}s" if code == "c" else f"{count}{code}" if count > 1 else code)
    return codes


def _fields(*lines: str) -> str:
    return "".join(f"{line};" for line in lines)


VEHICLE_ATTITUDE = Topic("vehicle_attitude", 50_000, _fields(
    "uint64_t timestamp", "uint64_t timestamp_sample", "float[4] q", "float[4] delta_q_reset",
    "uint8_t quat_reset_counter"))  # fmt: skip
VEHICLE_ATTITUDE_SETPOINT = Topic("vehicle_attitude_setpoint", 50_000, _fields(
    "uint64_t timestamp", "float roll_body", "float pitch_body", "float yaw_body", "float yaw_sp_move_rate",
    "float[4] q_d", "float[3] thrust_body", "bool reset_integral", "bool fw_control_yaw_wheel"))  # fmt: skip
VEHICLE_RATES_SETPOINT = Topic("vehicle_rates_setpoint", 20_000, _fields(
    "uint64_t timestamp", "float roll", "float pitch", "float yaw", "float[3] thrust_body",
    "bool reset_integral"))  # fmt: skip
VEHICLE_LOCAL_POSITION = Topic("vehicle_local_position", 100_000, _fields(
    "uint64_t timestamp", "uint64_t timestamp_sample", "bool xy_valid", "bool z_valid", "bool v_xy_valid",
    "bool v_z_valid", "float x", "float y", "float z", "float[2] delta_xy", "uint8_t xy_reset_counter",
    "float delta_z", "uint8_t z_reset_counter", "float vx", "float vy", "float vz", "float z_deriv",
    "float[2] delta_vxy", "uint8_t vxy_reset_counter", "float delta_vz", "uint8_t vz_reset_counter", "float ax",
    "float ay", "float az", "float heading", "float heading_var", "float unaided_heading", "float delta_heading",
    "uint8_t heading_reset_counter", "bool heading_good_for_control", "float tilt_var", "bool xy_global",
    "bool z_global", "uint64_t ref_timestamp", "double ref_lat", "double ref_lon", "float ref_alt",
    "float dist_bottom", "bool dist_bottom_valid", "uint8_t dist_bottom_sensor_bitfield", "float eph", "float epv",
    "float evh", "float evv", "bool dead_reckoning", "float vxy_max", "float vz_max", "float hagl_min",
    "float hagl_max"))  # fmt: skip
VEHICLE_LOCAL_POSITION_SETPOINT = Topic("vehicle_local_position_setpoint", 100_000, _fields(
    "uint64_t timestamp", "float x", "float y", "float z", "float vx", "float vy", "float vz",
    "float[3] acceleration", "float[3] thrust", "float yaw", "float yawspeed"))  # fmt: skip
TRAJECTORY_SETPOINT = Topic("trajectory_setpoint", 200_000, _fields(
    "uint64_t timestamp", "float[3] position", "float[3] velocity", "float[3] acceleration", "float[3] jerk",
    "float yaw", "float yawspeed"))  # fmt: skip
VEHICLE_GLOBAL_POSITION = Topic("vehicle_global_position", 200_000, _fields(
    "uint64_t timestamp", "uint64_t timestamp_sample", "double lat", "double lon", "float alt", "float alt_ellipsoid",
    "float delta_alt", "uint8_t lat_lon_reset_counter", "uint8_t alt_reset_counter", "float eph", "float epv",
    "float terrain_alt", "bool terrain_alt_valid", "bool dead_reckoning"))  # fmt: skip
VEHICLE_STATUS = Topic("vehicle_status", ON_CHANGE, _fields(
    "uint64_t timestamp", "uint64_t armed_time", "uint64_t takeoff_time", "uint8_t arming_state",
    "uint8_t latest_arming_reason", "uint8_t latest_disarming_reason", "uint64_t nav_state_timestamp",
    "uint8_t nav_state_user_intention", "uint8_t nav_state", "uint8_t executor_in_charge",
    "uint32_t valid_nav_states_mask", "uint32_t can_set_nav_states_mask", "uint16_t failure_detector_status",
    "uint8_t hil_state", "uint8_t vehicle_type", "bool failsafe", "bool failsafe_and_user_took_over",
    "uint8_t failsafe_defer_state", "bool gcs_connection_lost", "uint8_t gcs_connection_lost_counter",
    "bool high_latency_data_link_lost", "bool is_vtol", "bool is_vtol_tailsitter", "bool in_transition_mode",
    "bool in_transition_to_fw", "uint8_t system_type", "uint8_t system_id", "uint8_t component_id",
    "bool safety_button_available", "bool safety_off", "bool power_input_valid", "bool usb_connected",
    "bool open_drone_id_system_present", "bool open_drone_id_system_healthy", "bool parachute_system_present",
    "bool parachute_system_healthy", "bool avoidance_system_required", "bool avoidance_system_valid",
    "bool rc_calibration_in_progress", "bool calibration_enabled", "bool pre_flight_checks_pass"))  # fmt: skip
VTOL_VEHICLE_STATUS = Topic("vtol_vehicle_status", 200_000, _fields(
    "uint64_t timestamp", "uint8_t vehicle_vtol_state", "bool fixed_wing_system_failure"))  # fmt: skip
ACTUATOR_MOTORS = Topic("actuator_motors", 100_000, _fields(
    "uint64_t timestamp", "uint64_t timestamp_sample", "uint16_t reversible_flags", "float[12] control"))  # fmt: skip
ACTUATOR_SERVOS = Topic("actuator_servos", 100_000, _fields(
    "uint64_t timestamp", "uint64_t timestamp_sample", "float[8] control"))  # fmt: skip
ACTUATOR_OUTPUTS = Topic("actuator_outputs", 100_000, _fields(
    "uint64_t timestamp", "uint32_t noutputs", "float[16] output"))  # fmt: skip
SENSOR_COMBINED = Topic("sensor_combined", IMU_INTERVAL_USEC, _fields(
    "uint64_t timestamp", "float[3] gyro_rad", "uint32_t gyro_integral_dt", "int32_t accelerometer_timestamp_relative",
    "float[3] accelerometer_m_s2", "uint32_t accelerometer_integral_dt", "uint8_t accelerometer_clipping",
    "uint8_t gyro_clipping", "uint8_t accel_calibration_count", "uint8_t gyro_calibration_count"))  # fmt: skip
BATTERY_STATUS = Topic("battery_status", 200_000, _fields(
    "uint64_t timestamp", "bool connected", "float voltage_v", "float voltage_filtered_v", "float current_a",
    "float current_filtered_a", "float current_average_a", "float discharged_mah", "float remaining", "float scale",
    "float time_remaining_s", "float temperature", "uint8_t cell_count", "uint8_t source", "uint8_t priority",
    "uint16_t capacity", "uint16_t cycle_count", "uint16_t average_time_to_empty", "uint16_t serial_number",
    "uint16_t manufacture_date", "uint16_t state_of_health", "uint16_t max_error", "uint8_t id",
    "uint16_t interface_error", "float[14] voltage_cell_v", "float max_cell_voltage_delta", "bool is_powering_off",
    "bool is_required", "uint16_t faults", "uint32_t custom_faults", "uint8_t warning", "uint8_t mode",
    "float average_power", "float available_energy", "float full_charge_capacity_wh", "float remaining_capacity_wh",
    "float design_capacity", "uint16_t average_time_to_full", "uint16_t over_discharge_count",
    "float nominal_voltage"))  # fmt: skip
FAILURE_DETECTOR_STATUS = Topic("failure_detector_status", 100_000, _fields(
    "uint64_t timestamp", "bool fd_roll", "bool fd_pitch", "bool fd_alt", "bool fd_ext", "bool fd_arm_escs",
    "bool fd_battery", "bool fd_imbalanced_prop", "bool fd_motor", "float imbalanced_prop_metric",
    "uint16_t motor_failure_mask"))  # fmt: skip
HOME_POSITION = Topic("home_position", ON_CHANGE, _fields(
    "uint64_t timestamp", "double lat", "double lon", "float alt", "float x", "float y", "float z", "float yaw",
    "bool valid_alt", "bool valid_hpos", "bool valid_lpos", "bool manual_home", "uint32_t update_count"))  # fmt: skip
MISSION_RESULT = Topic("mission_result", ON_CHANGE, _fields(
    "uint64_t timestamp", "uint32_t mission_id", "uint32_t geofence_id", "uint32_t home_position_counter",
    "int32_t seq_reached", "uint16_t seq_current", "uint16_t seq_total", "bool valid", "bool warning",
    "bool finished", "bool failure", "bool item_do_jump_changed", "uint16_t item_changed_index",
    "uint16_t item_do_jump_remaining", "uint8_t execution_mode"))  # fmt: skip
# Ours: each solve of the unified MPC (100 Hz while it flies); hpipm_status: HPIPM's 0 SUCCESS, 1 MAX_ITER, 2 MIN_STEP,
# 3 NAN_SOL, 4 INCONS_EQ (255: another failure).
TILTROTOR_MPC_STATUS = Topic("tiltrotor_mpc_status", ON_CHANGE, _fields(
    "uint64_t timestamp", "float solve_time_ms", "uint32_t qp_iterations", "float cost", "bool ok",
    "bool fell_back_to_pid", "uint8_t hpipm_status"))  # fmt: skip

TOPICS: tuple[Topic, ...] = (
    VEHICLE_ATTITUDE, VEHICLE_ATTITUDE_SETPOINT, VEHICLE_RATES_SETPOINT, VEHICLE_LOCAL_POSITION,
    VEHICLE_LOCAL_POSITION_SETPOINT, TRAJECTORY_SETPOINT, VEHICLE_GLOBAL_POSITION, VEHICLE_STATUS,
    VTOL_VEHICLE_STATUS, ACTUATOR_MOTORS, ACTUATOR_SERVOS, ACTUATOR_OUTPUTS, SENSOR_COMBINED, BATTERY_STATUS,
    FAILURE_DETECTOR_STATUS, HOME_POSITION, MISSION_RESULT, TILTROTOR_MPC_STATUS,
)  # fmt: skip
