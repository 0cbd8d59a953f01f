"""PX4-style mode-switching PID velocity controller for the tilt-rotor (docs/autopilot.md): the paper's baseline.

Phases, as PX4's standard VTOL logic runs them for a tiltrotor, one method each as in PX4's vtol_type (update_phase
switches between them):
  MC             multicopter velocity PID -> acceleration -> attitude + collective thrust; rotors up (tilt 0).
  TRANSITION_FW  triggered when the horizontal set-point exceeds MPC_XY_VEL_MAX: rotors to VT_TILT_TRANS with
                 pitch held, altitude by collective thrust, forward acceleration as fast as the tilt gives;
                 multicopter and fixed-wing commands blended by airspeed between VT_ARSP_BLEND and
                 VT_ARSP_TRANS; past VT_ARSP_TRANS rotors to 90 deg, then FW.
  FW             fixed wing: airspeed PID on thrust, climb-rate PID on pitch, coordinated turns (bank from the
                 course error and the set-point's turn rate, yaw along the track).
  TRANSITION_MC  back transition when the set-point drops below FW_AIRSPD_MIN: rotors back to 0, multicopter
                 control with the deceleration limited to VT_B_DEC_MSS; MC again below MPC_XY_VEL_MAX.
Parameter names follow PX4 where PX4 has them; each gain and limit is a parameter (autopilot/control/tuning.py),
applied at the next tick when it changes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aircraft.airframe import Airframe
from aircraft.frames import wrap
from autopilot.control.velocity_command import SetpointTrajectory, VelocityCommand, course_rate, setpoint_course
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawReference

MC, TRANSITION_FW, FW, TRANSITION_MC = "MC", "TRANSITION_FW", "FW", "TRANSITION_MC"


@dataclass(frozen=True)
class PidParameters:
    """Gains and limits, declared once: their defaults here, the parameter of each in the comment (ours where PX4
    has no such gain)."""

    mc_vel_p_xy: float = 1.8  # MPC_XY_VEL_P_ACC (1/s)
    mc_vel_i_xy: float = 0.4  # MPC_XY_VEL_I_ACC (1/s^2)
    mc_vel_p_z: float = 4.0  # MPC_Z_VEL_P_ACC
    mc_vel_i_z: float = 2.0  # MPC_Z_VEL_I_ACC
    mc_vel_int_z_max: float = 4.0  # m/s^2 the vertical integrator may supply at most (not a parameter)
    mc_tilt_max_deg: float = 35.0  # MPC_TILTMAX_AIR
    mc_acc_hor_max: float = 6.0  # MPC_ACC_HOR_MAX (m/s^2)
    mc_acc_up_max: float = 6.0  # MPC_ACC_UP_MAX (m/s^2)
    mc_acc_down_max: float = 4.0  # MPC_ACC_DOWN_MAX (m/s^2)
    mc_yawrate_max_deg: float = 45.0  # MC_YAWRATE_MAX (PX4: 200): the fastest yaw reference rate the PID turns at
    mc_speed_max: float = 12.0  # MPC_XY_VEL_MAX (m/s): above it the set-point asks for forward flight
    arsp_blend: float = 13.5  # VT_ARSP_BLEND (m/s)
    arsp_trans: float = 23.0  # VT_ARSP_TRANS (m/s)
    tilt_trans_deg: float = 30.0  # VT_TILT_TRANS x 90 deg
    tilt_fw_deg: float = 90.0  # PX4's VT_TILT_FW x 90 deg (not a parameter)
    tilt_fw_margin_deg: float = 2.0  # the forward transition is complete with the mean tilt this close to tilt_fw
    tilt_mc_deg: float = 5.0  # the back transition is complete with the mean tilt below this
    trans_pitch_deg: float = 0.0  # pitch held while the rotors pull the aircraft through the transition
    back_trans_decel: float = 2.0  # VT_B_DEC_MSS (m/s^2)
    fw_airspd_min: float = 20.0  # FW_AIRSPD_MIN (m/s): slower set-points bring the rotors back up
    fw_speed_p: float = 1.0  # VT_FW_SPD_P: airspeed error -> along-track acceleration (1/s)
    fw_speed_i: float = 0.3  # VT_FW_SPD_I (1/s^2)
    fw_speed_int_max: float = 10.0  # m: airspeed integrator bound (not a parameter)
    fw_acc_max: float = 4.0  # m/s^2: along-track acceleration limit (not a parameter)
    fw_climb_p: float = 0.08  # VT_FW_CLMB_P: sink-rate error -> pitch (rad per m/s)
    fw_climb_i: float = 0.05  # VT_FW_CLMB_I (rad per m)
    fw_climb_int_max: float = 5.0  # m: sink integrator bound (not a parameter)
    fw_pitch_max_deg: float = 20.0  # FW_P_LIM_MAX
    fw_roll_max_deg: float = 35.0  # FW_R_LIM
    fw_course_p: float = 0.8  # VT_FW_CRS_P: course error -> turn rate (1/s)
    course_airspeed_min: float = 5.0  # m/s: slower, the nose follows the yaw set-point instead of the track
    yaw_attitude_gain: float = 3.0  # MC_YAW_P (1/s): the attitude loop's, by which a turning yaw set-point leads


def clamp(value: float, low: float, high: float) -> float:
    return low if value < low else high if value > high else value


class PidVelocityController:
    """Velocity set-point (NED, m/s) -> VelocityCommand, with PX4-like VTOL phase switching."""

    def __init__(self, airframe: Airframe, parameters: PidParameters = PidParameters(), dt: float = 0.01) -> None:
        self.airframe = airframe
        self.p = parameters
        self.dt = dt
        self.phase = MC
        self.mode_switches = 0
        self.integral_xy = np.zeros(2)
        self.integral_z = 0.0
        self.integral_speed = 0.0
        self.integral_climb = 0.0
        self.yaw_hold: float | None = None
        self.trajectory = SetpointTrajectory()  # the set-point's rate: the turn's feed-forward
        self.setpoint_rate = np.zeros(3)
        self._gravity = np.array([0.0, 0.0, airframe.gravity])

    def set_parameters(self, parameters: PidParameters) -> None:
        """Gains and limits from the next tick on (integrators and phase kept, as PX4 applies its gains in flight)."""
        self.p = parameters

    # ---- the controller ----------------------------------------------------------------------------------
    def update(self, state: VehicleState, v_sp: np.ndarray, tilts: np.ndarray,
               yaw: YawReference | None = None) -> VelocityCommand:  # fmt: skip
        """One 100 Hz step. `tilts` is the autopilot's estimate of the rotors' present tilts (rad); `yaw` the yaw
        reference to follow (None: the set-point's course, or the yaw held at low speed)."""
        self.setpoint_rate = self.trajectory.update(state.time_usec, v_sp)
        v_sp = self.trajectory.now(state.time_usec)  # slower set-points carried on along their rate
        speed_sp = math.hypot(v_sp[0], v_sp[1])
        self.update_phase(state, speed_sp, float(np.mean(tilts)))
        yaw_sp = self._yaw_setpoint(state, v_sp, yaw)
        if self.phase == MC:
            return self.multicopter(state, v_sp, yaw_sp)
        if self.phase == TRANSITION_FW:
            return self.transition_fw(state, v_sp, speed_sp, yaw_sp)
        if self.phase == FW:
            return self.fixed_wing(state, v_sp, speed_sp, yaw_sp)
        return self.transition_mc(state, v_sp, speed_sp, yaw_sp)

    # ---- phase switching ---------------------------------------------------------------------------------
    def update_phase(self, state: VehicleState, speed_sp: float, mean_tilt: float) -> None:
        """The transitions of PX4's standard VTOL logic, from the set-point's horizontal speed, the airspeed and
        the rotors' mean tilt (rad)."""
        p = self.p
        rotors_forward = mean_tilt >= math.radians(p.tilt_fw_deg - p.tilt_fw_margin_deg)
        rotors_up = mean_tilt < math.radians(p.tilt_mc_deg)
        if self.phase == MC and speed_sp > p.mc_speed_max:
            self._switch(TRANSITION_FW)
            self.integral_speed = 0.0
            self.integral_climb = 0.0
        elif self.phase == TRANSITION_FW:
            if speed_sp < p.mc_speed_max:
                self._switch(TRANSITION_MC)
            elif state.airspeed >= p.arsp_trans and rotors_forward:
                self._switch(FW)
        elif self.phase == FW and speed_sp < p.fw_airspd_min:
            self._switch(TRANSITION_MC)
            self.integral_xy[:] = 0.0
        elif self.phase == TRANSITION_MC and state.airspeed < p.mc_speed_max and rotors_up:
            self._switch(MC)
            self.integral_xy[:] = 0.0  # as PX4 resets its integrators at a transition

    def _switch(self, phase: str) -> None:
        if phase != self.phase:
            self.phase = phase
            self.mode_switches += 1

    # ---- the phases --------------------------------------------------------------------------------------
    def multicopter(self, state: VehicleState, v_sp: np.ndarray, yaw_sp: float) -> VelocityCommand:
        """MC: velocity PID -> acceleration -> attitude and collective thrust, rotors up, yaw by differential tilt."""
        p, a = self.p, self.airframe
        tilt_limit = math.radians(p.mc_tilt_max_deg)
        acceleration = self._mc_acceleration(state, v_sp, min(p.mc_acc_hor_max, a.gravity * math.tan(tilt_limit)))
        force_ned = a.mass * (acceleration - self._gravity)
        roll, pitch = self._attitude_from_force(force_ned, yaw_sp, tilt_limit)
        return self._command(state, force_ned, (roll, pitch, yaw_sp), 0.0, (0.0, 0.0, 1.0), yaw_by_tilt=True)

    def transition_fw(self, state: VehicleState, v_sp: np.ndarray, speed_sp: float, yaw_sp: float) -> VelocityCommand:
        """TRANSITION_FW: rotors at VT_TILT_TRANS until VT_ARSP_TRANS, then forward; commands blended by airspeed."""
        p = self.p
        blend = self._airspeed_blend(state)
        tilt = p.tilt_trans_deg if state.airspeed < p.arsp_trans else p.tilt_fw_deg
        return self._forward_flight(state, v_sp, speed_sp, yaw_sp, blend, math.radians(tilt), hold_yaw=blend < 1.0)

    def fixed_wing(self, state: VehicleState, v_sp: np.ndarray, speed_sp: float, yaw_sp: float) -> VelocityCommand:
        """FW: the fixed-wing laws alone (the transition's blend at 1), rotors forward."""
        return self._forward_flight(state, v_sp, speed_sp, yaw_sp, 1.0, math.radians(self.p.tilt_fw_deg), False)

    def transition_mc(self, state: VehicleState, v_sp: np.ndarray, speed_sp: float, yaw_sp: float) -> VelocityCommand:
        """TRANSITION_MC: rotors up at once; the multicopter law decelerates (limited to VT_B_DEC_MSS) while the wing
        still flies, so the fixed-wing climb law keeps the pitch (and altitude) by airspeed blend."""
        p, a = self.p, self.airframe
        tilt_limit = math.radians(p.mc_tilt_max_deg)
        blend = self._airspeed_blend(state)
        mc_acceleration = self._mc_acceleration(state, v_sp, p.back_trans_decel, integrate_xy=False)
        _, fw_pitch, fw_roll = self._fw_commands(state, v_sp, speed_sp)
        acceleration = mc_acceleration.copy()
        acceleration[2] *= 1.0 - blend
        force_ned = a.mass * (acceleration - self._gravity)
        mc_roll, mc_pitch = self._attitude_from_force(force_ned, yaw_sp, tilt_limit)
        euler_sp = ((1 - blend) * mc_roll + blend * fw_roll, (1 - blend) * mc_pitch + blend * fw_pitch, yaw_sp)
        return self._command(state, force_ned, euler_sp, 0.0, (0.0, 0.0, 1.0 - blend))

    def _forward_flight(
        self, state: VehicleState, v_sp: np.ndarray, speed_sp: float, yaw_sp: float, blend: float, tilt: float,
        hold_yaw: bool,
    ) -> VelocityCommand:  # fmt: skip
        """TRANSITION_FW and FW: multicopter and fixed-wing commands blended by `blend` (1 = fixed wing alone)."""
        p, a = self.p, self.airframe
        fw_acceleration, fw_pitch, fw_roll = self._fw_commands(state, v_sp, speed_sp)
        mc_acceleration = self._mc_acceleration(state, v_sp, p.mc_acc_hor_max)
        tilt_limit = math.radians(p.mc_tilt_max_deg)
        mc_roll, _ = self._attitude_from_force(a.mass * (mc_acceleration - self._gravity), yaw_sp, tilt_limit)
        # Vertical: collective thrust holds altitude while the wing cannot (weight 1 - blend);
        # the fixed-wing climb law on pitch takes over as airspeed builds.
        acceleration = blend * fw_acceleration
        acceleration[2] = (1.0 - blend) * mc_acceleration[2]
        force_ned = a.mass * (acceleration - self._gravity)
        pitch = (1.0 - blend) * math.radians(p.trans_pitch_deg) + blend * fw_pitch
        roll = (1.0 - blend) * mc_roll + blend * fw_roll
        if hold_yaw:
            yaw = yaw_sp
        else:
            track = math.atan2(state.velocity_ned[1], state.velocity_ned[0])
            course = track if state.airspeed > p.course_airspeed_min else yaw_sp
            # Coordinated turn: the nose leads the track by the attitude loop's yaw lag (turn rate / K_att,yaw),
            # so the sideslip, and the side force that would fight the turn, stay near zero.
            turn_rate = a.gravity * math.tan(state.euler[0]) / max(state.airspeed, 1.0)
            yaw = course + turn_rate / p.yaw_attitude_gain
        return self._command(state, force_ned, (roll, pitch, yaw), tilt, (blend, 0.0, 1.0 - blend))

    # ---- laws shared by the phases -----------------------------------------------------------------------
    def _command(
        self, state: VehicleState, force_ned: np.ndarray, euler_sp: tuple[float, float, float], tilt: float,
        force_weights: tuple[float, float, float], yaw_by_tilt: bool = False,
    ) -> VelocityCommand:  # fmt: skip
        command = VelocityCommand(mode=self.phase, yaw_by_tilt=yaw_by_tilt)
        command.euler_sp[:] = euler_sp
        command.tilt_sp[:] = tilt
        command.force_weights[:] = force_weights
        command.force_sp_body[:] = state.rotation().T @ force_ned
        return command

    def _airspeed_blend(self, state: VehicleState) -> float:
        """0 below VT_ARSP_BLEND, 1 from VT_ARSP_TRANS on, linear in between."""
        p = self.p
        return clamp((state.airspeed - p.arsp_blend) / (p.arsp_trans - p.arsp_blend), 0.0, 1.0)

    def _yaw_setpoint(self, state: VehicleState, v_sp: np.ndarray, reference: YawReference | None) -> float:
        if reference is not None:  # leads by the attitude loop's lag, so the yaw turns at the reference's rate
            self.yaw_hold = None
            limit = math.radians(self.p.mc_yawrate_max_deg)
            return reference.yaw + clamp(reference.rate, -limit, limit) / self.p.yaw_attitude_gain
        course = setpoint_course(v_sp[0], v_sp[1])
        if course is not None:
            self.yaw_hold = None
            return course
        if self.yaw_hold is None:
            self.yaw_hold = float(state.euler[2])
        return self.yaw_hold

    def _mc_acceleration(
        self, state: VehicleState, v_sp: np.ndarray, horizontal_limit: float, integrate_xy: bool = True
    ) -> np.ndarray:
        """Multicopter velocity PID: NED acceleration set-point (m/s^2) with anti-windup."""
        p = self.p
        error = v_sp - state.velocity_ned
        # Integrators may supply up to the acceleration limit (a jammed tilted rotor needs ~4 m/s^2 of trim).
        xy_limit, z_limit = p.mc_acc_hor_max / p.mc_vel_i_xy, p.mc_vel_int_z_max / p.mc_vel_i_z
        self.integral_z = clamp(self.integral_z + error[2] * self.dt, -z_limit, z_limit)
        horizontal = p.mc_vel_p_xy * error[0:2] + p.mc_vel_i_xy * self.integral_xy
        norm = float(np.hypot(*horizontal))
        if norm > horizontal_limit:
            horizontal *= horizontal_limit / norm
        elif integrate_xy:  # anti-windup: integrate only while the output is not saturated
            self.integral_xy = np.clip(self.integral_xy + error[0:2] * self.dt, -xy_limit, xy_limit)
        vertical = clamp(p.mc_vel_p_z * error[2] + p.mc_vel_i_z * self.integral_z, -p.mc_acc_up_max, p.mc_acc_down_max)
        return np.array([horizontal[0], horizontal[1], vertical])

    def _attitude_from_force(self, force_ned: np.ndarray, yaw: float, tilt_limit: float) -> tuple[float, float]:
        """Roll and pitch that point the rotors' thrust (tilt 0) along force_ned, for a given yaw."""
        forward = math.cos(yaw) * force_ned[0] + math.sin(yaw) * force_ned[1]
        right = -math.sin(yaw) * force_ned[0] + math.cos(yaw) * force_ned[1]
        up = max(-force_ned[2], 1e-3)
        pitch = clamp(-math.atan2(forward, up), -tilt_limit, tilt_limit)
        roll = clamp(math.atan2(right, math.hypot(forward, up)), -tilt_limit, tilt_limit)
        return roll, pitch

    def _fw_commands(self, state: VehicleState, v_sp: np.ndarray, speed_sp: float) -> tuple[np.ndarray, float, float]:
        """Fixed-wing laws: (NED acceleration wanted, pitch set-point, roll set-point)."""
        p = self.p
        g = self.airframe.gravity
        speed = max(state.airspeed, 1.0)
        speed_error = speed_sp - state.airspeed
        speed_bound = p.fw_speed_int_max
        self.integral_speed = clamp(self.integral_speed + speed_error * self.dt, -speed_bound, speed_bound)
        along = clamp(p.fw_speed_p * speed_error + p.fw_speed_i * self.integral_speed, -p.fw_acc_max, p.fw_acc_max)
        sink_error = state.velocity_ned[2] - v_sp[2]  # positive: sinking faster than wanted -> nose up
        climb_bound = p.fw_climb_int_max
        self.integral_climb = clamp(self.integral_climb + sink_error * self.dt, -climb_bound, climb_bound)
        pitch_limit = math.radians(p.fw_pitch_max_deg)
        pitch = clamp(p.fw_climb_p * sink_error + p.fw_climb_i * self.integral_climb, -pitch_limit, pitch_limit)
        course = math.atan2(state.velocity_ned[1], state.velocity_ned[0])
        course_sp = math.atan2(v_sp[1], v_sp[0])
        # Feed-forward of the set-point's own turning, from its rate over the set-point interval (a per-tick
        # difference alternated between 0 and twice the rate with 50 Hz offboard set-points).
        turn_rate = p.fw_course_p * wrap(course_sp - course) + course_rate(v_sp, self.setpoint_rate)
        roll_limit = math.radians(p.fw_roll_max_deg)
        roll = clamp(math.atan(speed * turn_rate / g), -roll_limit, roll_limit)
        track = np.array([math.cos(course), math.sin(course), 0.0])
        lateral = np.array([-math.sin(course), math.cos(course), 0.0])
        acceleration = along * track + g * math.tan(roll) * lateral
        return acceleration, pitch, roll
