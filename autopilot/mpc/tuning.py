"""The unified MPC's weights (paper Table 2) and limits from the parameters (VT_MPC_*, ours: PX4 has no MPC), and
its model of the attitude loop from the loop's own (MC_*). Pure functions of the parameter store; the MPC applies
them at the next solve (MpcVelocityController.retune).
"""

from __future__ import annotations

import math
from dataclasses import replace

from autopilot.mpc.model import MpcLimits, MpcWeights
from autopilot.storage.parameters import ParameterStore


def mpc_weights(params: ParameterStore, base: MpcWeights = MpcWeights()) -> MpcWeights:
    """`base` (a horizon's weights) with the Table 2 weights from VT_MPC_Q_*, VT_MPC_QF_*, VT_MPC_R_*, and the rotors'
    moment bound's from VT_MPC_Q_MOM and VT_MPC_Q_MOM_SRV, the velocity weights' factor with a rotor failed from
    VT_MPC_QV_FAIL."""
    return replace(
        base,
        q_ref=(params["VT_MPC_Q_VN"], params["VT_MPC_Q_VE"], params["VT_MPC_Q_VD"]),
        q_final=(params["VT_MPC_QF_VN"], params["VT_MPC_QF_VE"], params["VT_MPC_QF_VD"]),
        q_psi=(params["VT_MPC_Q_ROLL"], params["VT_MPC_Q_PITCH"], params["VT_MPC_Q_YAW"]),
        q_psi_dot=(params["VT_MPC_Q_ROLLR"], params["VT_MPC_Q_PITCHR"], params["VT_MPC_Q_YAWR"]),
        r_thrust=params["VT_MPC_R_THR"],
        r_rotor_lift=params["VT_MPC_R_LIFT"],
        r_tilt_rate=params["VT_MPC_R_TILTR"],
        r_psi_d=(params["VT_MPC_R_ROLLSP"], params["VT_MPC_R_PTCHSP"], params["VT_MPC_R_YAWSP"]),
        q_moment_bound=params["VT_MPC_Q_MOM"],
        q_moment_bound_servo=params["VT_MPC_Q_MOM_SRV"],
        q_velocity_rotor_failed=params["VT_MPC_QV_FAIL"],
    )


def mpc_limits(params: ParameterStore, base: MpcLimits = MpcLimits()) -> MpcLimits:
    """`base` with the roll and pitch bound, their set-points' bound, the velocity bounds and the tilt rate from
    VT_MPC_ATT_MAX, VT_MPC_ATTSP_MAX, VT_MPC_VXY_MAX, VT_MPC_VZ_MAX, VT_MPC_TILTR_MAX."""
    attitude, attitude_sp = math.radians(params["VT_MPC_ATT_MAX"]), math.radians(params["VT_MPC_ATTSP_MAX"])
    horizontal, vertical = params["VT_MPC_VXY_MAX"], params["VT_MPC_VZ_MAX"]
    return replace(
        base,
        attitude=(attitude, attitude),
        attitude_sp=(attitude_sp, attitude_sp),
        velocity=(horizontal, horizontal, vertical),
        tilt_rate=math.radians(params["VT_MPC_TILTR_MAX"]),
    )
