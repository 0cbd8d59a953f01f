"""The control stack's gains and limits from the parameters (docs/mavlink.md section 9): the attitude loop's under
PX4's MC_* names, the PID baseline's under PX4's MPC_*, FW_*, VT_* names and ours (VT_FW_*) where PX4 has no such
gain. Pure functions of the parameter store; the flight controller applies them at start and whenever a parameter
changes, in flight too (as PX4's controllers apply theirs).
"""

from __future__ import annotations

from dataclasses import replace

from autopilot.control.attitude import AttitudeGains
from autopilot.control.pid_baseline import PidParameters
from autopilot.storage.parameters import ParameterStore


def attitude_gains(params: ParameterStore) -> AttitudeGains:
    """MC_ROLL_P, MC_PITCH_P, MC_YAW_P (attitude), MC_*RATE_P (rate), MC_*RATE_D (rate damping)."""
    return AttitudeGains(
        attitude=(params["MC_ROLL_P"], params["MC_PITCH_P"], params["MC_YAW_P"]),
        rate_p=(params["MC_ROLLRATE_P"], params["MC_PITCHRATE_P"], params["MC_YAWRATE_P"]),
        rate_d=(params["MC_ROLLRATE_D"], params["MC_PITCHRATE_D"], params["MC_YAWRATE_D"]),
    )


def pid_parameters(params: ParameterStore) -> PidParameters:
    """The PID baseline's gains and limits: those that are parameters from `params`, the others the defaults."""
    return replace(
        PidParameters(),
        mc_vel_p_xy=params["MPC_XY_VEL_P_ACC"],
        mc_vel_i_xy=params["MPC_XY_VEL_I_ACC"],
        mc_vel_p_z=params["MPC_Z_VEL_P_ACC"],
        mc_vel_i_z=params["MPC_Z_VEL_I_ACC"],
        mc_tilt_max_deg=params["MPC_TILTMAX_AIR"],
        mc_acc_hor_max=params["MPC_ACC_HOR_MAX"],
        mc_acc_up_max=params["MPC_ACC_UP_MAX"],
        mc_acc_down_max=params["MPC_ACC_DOWN_MAX"],
        mc_yawrate_max_deg=params["MC_YAWRATE_MAX"],
        mc_speed_max=params["MPC_XY_VEL_MAX"],
        arsp_blend=params["VT_ARSP_BLEND"],
        arsp_trans=params["VT_ARSP_TRANS"],
        tilt_trans_deg=params["VT_TILT_TRANS"] * 90.0,
        back_trans_decel=params["VT_B_DEC_MSS"],
        fw_airspd_min=params["FW_AIRSPD_MIN"],
        fw_speed_p=params["VT_FW_SPD_P"],
        fw_speed_i=params["VT_FW_SPD_I"],
        fw_climb_p=params["VT_FW_CLMB_P"],
        fw_climb_i=params["VT_FW_CLMB_I"],
        fw_pitch_max_deg=params["FW_P_LIM_MAX"],
        fw_roll_max_deg=params["FW_R_LIM"],
        fw_course_p=params["VT_FW_CRS_P"],
        yaw_attitude_gain=params["MC_YAW_P"],
    )
