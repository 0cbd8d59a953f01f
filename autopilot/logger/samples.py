"""What each logged topic holds, from what the flight stack knows this step: one function a topic, returning the
topic's fields as a flat tuple in their order (autopilot/logger/topics.py).

Where this vehicle has no counterpart of a PX4 field the field holds PX4's own "not there" value: NaN for a set-point
that is not controlled, 0 for reset deltas and counters (the estimate is the plant's truth: it never resets), false
for systems the vehicle has not (parachute, Remote ID, RC calibration), INFINITY for speed limits the estimator does
not impose.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from aircraft.actuators import PWM_MAX, PWM_MIN, ROTOR_COUNT, ROTORS, SERVO_CHANNELS
from aircraft.failures import Failure, FailureType, FailureUnit
from aircraft.frames import quaternion_from_euler
from autopilot.control.attitude import GAIN_COUNT, AttitudeGains, euler_rate_matrix, euler_rate_setpoint
from autopilot.mpc.hpipm import HPIPM_STATUS
from autopilot.topics.flight_mode import (
    PX4_AUTO_FOLLOW_TARGET,
    PX4_AUTO_LAND,
    PX4_AUTO_LOITER,
    PX4_AUTO_MISSION,
    PX4_AUTO_RTL,
    PX4_AUTO_TAKEOFF,
    PX4_MAIN_ALTCTL,
    PX4_MAIN_AUTO,
    PX4_MAIN_OFFBOARD,
    PX4_MAIN_POSCTL,
    PX4_POSCTL_ORBIT,
    ModeId,
)
from autopilot.topics.home_position import HomePosition
from autopilot.topics.missions import Missions
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawReference
from transport.geodesy import Home, LocalGeodetic
from transport.mavlink import mavlink as M

NAN = math.nan
INF = math.inf
NAN3 = (NAN, NAN, NAN)
IMU_INTERVAL_USEC = 2500  # the plant's step: the samples' integration interval
PWM_CENTRE, PWM_HALF_RANGE = 1500.0, 500.0
BATTERY_CELLS, CELL_VOLTS = 4, 4.2  # the constant full 4S battery BATTERY_STATUS reports (the plant has none)

# PX4's vehicle_status constants (msg/VehicleStatus.msg).
ARMING_STATE_DISARMED, ARMING_STATE_ARMED = 1, 2
VEHICLE_TYPE_ROTARY_WING, VEHICLE_TYPE_FIXED_WING = 1, 2
NAV_STATE_ALTCTL, NAV_STATE_POSCTL, NAV_STATE_AUTO_MISSION, NAV_STATE_AUTO_LOITER = 1, 2, 3, 4
NAV_STATE_AUTO_RTL, NAV_STATE_TERMINATION, NAV_STATE_OFFBOARD = 5, 13, 14
NAV_STATE_AUTO_TAKEOFF, NAV_STATE_AUTO_LAND, NAV_STATE_AUTO_FOLLOW_TARGET, NAV_STATE_ORBIT = 17, 18, 19, 21
MISSION_EXECUTION_NORMAL = 0

_NAV_STATES = {
    (PX4_MAIN_AUTO, PX4_AUTO_LOITER): NAV_STATE_AUTO_LOITER, (PX4_MAIN_AUTO, PX4_AUTO_TAKEOFF): NAV_STATE_AUTO_TAKEOFF,
    (PX4_MAIN_AUTO, PX4_AUTO_LAND): NAV_STATE_AUTO_LAND, (PX4_MAIN_AUTO, PX4_AUTO_MISSION): NAV_STATE_AUTO_MISSION,
    (PX4_MAIN_AUTO, PX4_AUTO_RTL): NAV_STATE_AUTO_RTL, (PX4_MAIN_OFFBOARD, 0): NAV_STATE_OFFBOARD,
    (PX4_MAIN_POSCTL, 0): NAV_STATE_POSCTL, (PX4_MAIN_POSCTL, PX4_POSCTL_ORBIT): NAV_STATE_ORBIT,
    (PX4_MAIN_ALTCTL, 0): NAV_STATE_ALTCTL, (PX4_MAIN_AUTO, PX4_AUTO_FOLLOW_TARGET): NAV_STATE_AUTO_FOLLOW_TARGET,
}  # fmt: skip


def nav_state(mode: ModeId, terminated: bool) -> int:
    """PX4's navigation state (vehicle_status.nav_state) of a flight mode."""
    if terminated:
        return NAV_STATE_TERMINATION
    return _NAV_STATES.get((mode.main, mode.sub), NAV_STATE_AUTO_LOITER)


def nav_states_mask(modes: tuple[ModeId, ...]) -> int:
    """The bits (1 << nav_state) of the modes a ground station may choose."""
    return sum({1 << nav_state(mode, False) for mode in modes})


class BodyRateSetpoint:
    """The body rates (rad/s) the attitude loop's P law asks for, E(Psi) Psi_dot_sp with the loop's gains,
    evaluated in place (a CasADi call with numpy arguments costs ten times as much)."""

    def __init__(self) -> None:
        euler, euler_sp = ca.SX.sym("euler", 3), ca.SX.sym("euler_sp", 3)
        gains = ca.SX.sym("gains", GAIN_COUNT)
        rates = euler_rate_matrix(euler) @ euler_rate_setpoint(euler, euler_sp, gains)
        function = ca.Function("body_rate_setpoint", [euler, euler_sp, gains], [rates])
        self._buffer, self._evaluate = function.buffer()
        self.euler, self.euler_sp, self.rates = np.zeros(3), np.zeros(3), np.zeros(3)
        self.gains = np.zeros(GAIN_COUNT)
        self._buffer.set_arg(0, memoryview(self.euler))
        self._buffer.set_arg(1, memoryview(self.euler_sp))
        self._buffer.set_arg(2, memoryview(self.gains))
        self._buffer.set_res(0, memoryview(self.rates))

    def __call__(self, euler: np.ndarray, euler_sp: np.ndarray, gains: AttitudeGains) -> tuple[float, float, float]:
        self.euler[:] = euler
        self.euler_sp[:] = euler_sp
        self.gains[:] = gains.vector()
        self._evaluate()
        roll, pitch, yaw = self.rates.tolist()
        return roll, pitch, yaw


def normalised_thrust(force_sp_body: np.ndarray, thrust_max_total: float) -> tuple[float, float, float]:
    """The force set-point (body FRD, N) over the rotors' full thrust: PX4's thrust_body, -1..1."""
    fx, fy, fz = (float(v) / thrust_max_total for v in force_sp_body)
    return fx, fy, fz


def vehicle_attitude(t: int, state: VehicleState) -> tuple:
    return (t, t, *state.quaternion.tolist(), 0.0, 0.0, 0.0, 0.0, 0)


def vehicle_attitude_setpoint(t: int, euler_sp: np.ndarray, thrust_body: tuple[float, float, float],
                              yaw: YawReference | None) -> tuple:  # fmt: skip
    roll, pitch, yaw_sp = euler_sp.tolist()
    return (t, roll, pitch, yaw_sp, 0.0 if yaw is None else yaw.rate, *quaternion_from_euler(roll, pitch, yaw_sp),
            *thrust_body, False, False)  # fmt: skip


def vehicle_rates_setpoint(t: int, rates_sp: tuple[float, float, float], thrust_body: tuple[float, float, float]
                           ) -> tuple:  # fmt: skip
    return (t, *rates_sp, *thrust_body, False)


def acceleration_ned(state: VehicleState, gravity: float) -> tuple[float, float, float]:
    """The acceleration (NED, m/s^2): the accelerometer's specific force turned to NED, plus gravity."""
    r = state.rotation()
    north, east, down = (float(v) for v in r @ state.specific_force)
    return north, east, down + gravity


def vehicle_local_position(t: int, state: VehicleState, acceleration: tuple[float, float, float], origin: Home,
                           ref_usec: int) -> tuple:  # fmt: skip
    x, y, z = state.position_ned.tolist()
    vx, vy, vz = state.velocity_ned.tolist()
    heading = float(state.euler[2])
    return (t, t, True, True, True, True, x, y, z, 0.0, 0.0, 0, 0.0, 0, vx, vy, vz, vz, 0.0, 0.0, 0, 0.0, 0,
            *acceleration, heading, 0.0, NAN, 0.0, 0, True, 0.0, True, True, ref_usec, origin.lat, origin.lon,
            origin.alt, 0.0, False, 0, 0.0, 0.0, 0.0, 0.0, False, INF, INF, INF, INF)  # fmt: skip


def vehicle_local_position_setpoint(t: int, velocity_sp: np.ndarray, thrust_ned: tuple[float, float, float],
                                    euler_sp: np.ndarray, yaw: YawReference | None) -> tuple:  # fmt: skip
    return (t, NAN, NAN, NAN, *velocity_sp.tolist(), *NAN3, *thrust_ned, float(euler_sp[2]),
            NAN if yaw is None else yaw.rate)  # fmt: skip


def trajectory_setpoint(t: int, velocity_sp: np.ndarray, yaw: YawReference | None) -> tuple:
    return (t, *NAN3, *velocity_sp.tolist(), *NAN3, *NAN3, NAN if yaw is None else yaw.yaw,
            NAN if yaw is None else yaw.rate)  # fmt: skip


def vehicle_global_position(t: int, state: VehicleState, geodetic: LocalGeodetic) -> tuple:
    lat, lon, alt = geodetic.to_geodetic(*state.position_ned.tolist())
    return (t, t, lat, lon, alt, alt, 0.0, 0, 0, 0.0, 0.0, NAN, False, False)


def vehicle_status(t: int, *, armed: bool, armed_usec: int, takeoff_usec: int, nav: int, nav_usec: int,
                   valid_modes: int, fixed_wing: bool, transition: int, failsafe: bool, datalink_lost: bool,
                   system_id: int, started: bool) -> tuple:  # fmt: skip
    """transition: 0 none, 1 to fixed wing, 2 to multicopter (MAV_VTOL_STATE_TRANSITION_TO_FW / _MC)."""
    return (t, armed_usec, takeoff_usec, ARMING_STATE_ARMED if armed else ARMING_STATE_DISARMED, 0, 0, nav_usec, nav,
            nav, 0, valid_modes, valid_modes, 0, 0, VEHICLE_TYPE_FIXED_WING if fixed_wing else VEHICLE_TYPE_ROTARY_WING,
            failsafe, False, 0, datalink_lost, 0, False, True, False, transition != 0, transition == 1,
            M.MAV_TYPE_VTOL_TILTROTOR, system_id, 1, False, True, True, False, False, False, False, False, False,
            False, False, False, started)  # fmt: skip


def vtol_vehicle_status(t: int, mav_vtol_state: int) -> tuple:
    """PX4's VEHICLE_VTOL_STATE numbers are MAVLink's MAV_VTOL_STATE ones (1 to FW, 2 to MC, 3 MC, 4 FW)."""
    return (t, mav_vtol_state, False)


def actuator_motors(t: int, pwm: list[int] | tuple[int, ...]) -> tuple:
    """The rotors' thrust commands (0..1) as sent (PWM 1000..2000); PX4 fills the unused of its 12 with NaN."""
    return (t, t, 0, *((value - PWM_MIN) / (PWM_MAX - PWM_MIN) for value in pwm[ROTORS]), *([NAN] * (12 - ROTOR_COUNT)))


def actuator_servos(t: int, pwm: list[int] | tuple[int, ...]) -> tuple:
    """The tilt servos and surfaces as PX4 normalises servos, -1..1 over their PWM range."""
    return (t, t, *((value - PWM_CENTRE) / PWM_HALF_RANGE for value in pwm[SERVO_CHANNELS]))


def actuator_outputs(t: int, pwm: list[int] | tuple[int, ...]) -> tuple:
    return (t, len(pwm), *(float(value) for value in pwm), *([0.0] * (16 - len(pwm))))


def sensor_combined(t: int, state: VehicleState) -> tuple:
    return (t, *state.body_rates.tolist(), IMU_INTERVAL_USEC, 0, *state.specific_force.tolist(), IMU_INTERVAL_USEC,
            0, 0, 0, 0)  # fmt: skip


def battery_status(t: int) -> tuple:
    """BATTERY_STATUS's constant full 4S battery, as PX4's battery_status carries it."""
    volts = BATTERY_CELLS * CELL_VOLTS
    return (t, True, volts, volts, -1.0, -1.0, -1.0, NAN, 1.0, 1.0, NAN, NAN, BATTERY_CELLS, 0, 0, 0, 0, 0, 0, 0, 0,
            0, 0, 0, *([CELL_VOLTS] * BATTERY_CELLS), *([0.0] * (14 - BATTERY_CELLS)), 0.0, False, True, 0, 0, 0, 0,
            NAN, NAN, NAN, NAN, NAN, 0, 0, NAN)  # fmt: skip


def motor_failure_mask(failures: list[Failure] | tuple[Failure, ...]) -> int:
    """Bit i: rotor i+1 failed (a motor failure known to the controllers, not cleared since)."""
    mask = 0
    for failure in failures:
        if failure.unit is not FailureUnit.MOTOR:
            continue
        bits = (1 << ROTOR_COUNT) - 1 if failure.instance == 0 else 1 << (failure.instance - 1)
        mask = mask & ~bits if failure.kind is FailureType.OK else mask | bits
    return mask


def failure_detector_status(t: int, motor_mask: int) -> tuple:
    return (t, False, False, False, False, False, False, False, motor_mask != 0, NAN, motor_mask)


def home_position(t: int, home: HomePosition, update_count: int) -> tuple:
    return (t, home.lat, home.lon, home.alt, home.north, home.east, home.down, 0.0, True, True, True, home.manual,
            update_count)  # fmt: skip


def mission_result(t: int, missions: Missions, mission_id: int, fence_id: int, home_counter: int) -> tuple:
    total = len(missions.mission)
    return (t, mission_id, fence_id, home_counter, missions.reached, min(missions.current, 0xFFFF), min(total, 0xFFFF),
            total > 0, False, missions.state == M.MISSION_STATE_COMPLETE, False, False, 0, 0,
            MISSION_EXECUTION_NORMAL)  # fmt: skip


HPIPM_CODES = {name: code for code, name in HPIPM_STATUS.items()}
OTHER_FAILURE = 255


def mpc_status(t: int, solve_time_ms: float, iterations: int, cost: float, ok: bool, fell_back: bool,
               status: str) -> tuple:  # fmt: skip
    """status: the solve's HPIPM status name (autopilot/mpc/hpipm.py), logged as its code."""
    return (t, solve_time_ms, iterations, cost, ok, fell_back, HPIPM_CODES.get(status, OTHER_FAILURE))
