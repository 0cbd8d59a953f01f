"""The autopilot's parameters (docs/mavlink.md): PX4 names where PX4 has the parameter, PX4's bytewise MAVLink
encoding, and a parameter file that is written atomically and read back at start.

Encoding (MAVLink PARAM_VALUE / PARAM_SET, MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE): a REAL32 parameter
travels as its float value; an INT32 parameter travels as the four bytes of the int32 reinterpreted as the
float field (PX4's encoding; 1 is sent as the float 1.4e-45, not 1.0).

The file is JSON, only the values that differ from their default:

    {"format": "tiltrotor-sitl parameters", "version": 1, "parameters": {"SYS_FAILURE_EN": 1}}

It is replaced atomically on a background thread (autopilot/storage/kept_file.py).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from autopilot.storage.kept_file import BackgroundWriter, read_kept
from autopilot.storage.signing_key import SigningKey, SigningRefused, key_from_document, key_to_document
from transport.plant_parameters import INT32, PLANT_PARAMETERS, REAL32, decode_bytewise, encode_bytewise
from transport.ports import Ports

FILE_FORMAT = "tiltrotor-sitl parameters"
FILE_VERSION = 1

MAV_PARAM_TYPE_INT32 = 6
MAV_PARAM_TYPE_REAL32 = 9
MAV_TYPE_OF = {INT32: MAV_PARAM_TYPE_INT32, REAL32: MAV_PARAM_TYPE_REAL32}


@dataclass(frozen=True)
class ParameterDefinition:
    name: str
    kind: str  # INT32 or REAL32
    default: float
    minimum: float
    maximum: float
    unit: str
    description: str
    px4: bool = True  # False: this project's own parameter (PX4 has no such one)
    reboot_required: bool = False  # takes effect at the next start (the parameter metadata's rebootRequired)
    px4_default: float | None = None  # PX4's default where it differs from ours (None: the same, or not PX4's)
    px4_unit: str | None = None  # PX4's unit where ours differs (px4_default is in it): the same name, another law
    plant: bool = False  # True: the plant keeps it (the wind); shown and set here, never in the parameter file


P = ParameterDefinition
DEFINITIONS: tuple[ParameterDefinition, ...] = (
    P("MAV_SYS_ID", INT32, 1, 1, 250, "", "MAVLink system id of the vehicle (at the next start; --sysid overrides)"),
    P(
        "MAV_SIGN_REQ",
        INT32,
        1,
        0,
        1,
        "",
        "with a signing key set (SETUP_SIGNING): 1 refuses unsigned commands, 0 "
        "accepts them (outgoing messages are signed either way)",
        px4=False,
    ),
    P(
        "VT_CTRL",
        INT32,
        1,
        0,
        1,
        "",
        "velocity controller: 0 PID baseline, 1 unified MPC (at the next start or "
        "takeoff from the ground; --controller overrides at start)",
        px4=False,
    ),
    P(
        "VT_MPC_HRZN",
        INT32,
        0,
        0,
        1,
        "",
        "the MPC's horizon: 0 the paper's 25 stages of 10 ms, 1 the long one "
        "(2.05 s, experimental) (at the next start or takeoff from the ground; --mpc-horizon overrides at start)",
        px4=False,
    ),
    P(
        "VT_MPC_OVERLAP",
        INT32,
        0,
        0,
        1,
        "",
        "MPC solve: 0 synchronous (the paper's), 1 one control tick ahead on a "
        "second core, from the predicted state (at the next start or takeoff from the ground)",
        px4=False,
    ),
    P("SYS_FAILURE_EN", INT32, 0, 0, 1, "", "1 enables MAV_CMD_INJECT_FAILURE"),
    P(
        "SYS_FAILURE_DLY",
        REAL32,
        0.0,
        0.0,
        60.0,
        "s",
        "delay before the controllers learn of an injected failure",
        px4=False,
    ),
    P(
        "VT_FAIL_ORACLE",
        INT32,
        0,
        0,
        1,
        "",
        "0: the controllers learn of a motor or servo failure only from the failure detector (a stopped motor, a "
        "jammed tilt servo), as PX4's; 1: from the injection itself (the paper's known failures: vtol scenario)",
        px4=False,
    ),
    P(
        "FD_ACT_EN",
        INT32,
        1,
        0,
        1,
        "",
        "1: the failure detector checks each motor against its ESC telemetry (its RPM here, its current in PX4) "
        "and each tilt servo against the moment its rotor gives",
    ),
    P(
        "FD_ACT_MOT_THR",
        REAL32,
        0.05,
        0.0,
        1.0,
        "norm",
        "motor failure check: the thrust fraction from which it runs",
        px4_default=0.2,
    ),
    P(
        "FD_ACT_MOT_TOUT",
        INT32,
        50,
        10,
        10000,
        "ms",
        "motor failure check: failing this long is a motor failure",
        px4_default=100,
    ),
    P(
        "VT_FD_RPM_RATIO",
        REAL32,
        0.5,
        0.05,
        1.0,
        "",
        "motor failure check: a motor is failing while its RPM is below this fraction of what its command gives",
        px4=False,
    ),
    P(
        "VT_FD_SRV_MOM",
        REAL32,
        0.15,
        0.05,
        10.0,
        "N m",
        "tilt servo check: an unexplained moment from which the servos are examined",
        px4=False,
    ),
    P(
        "VT_FD_SRV_ANG",
        REAL32,
        2.0,
        1.0,
        90.0,
        "deg",
        "tilt servo check: a servo whose tilt explains the moment, this far from its estimate, is failing",
        px4=False,
    ),
    P(
        "VT_FD_SRV_TOUT",
        INT32,
        50,
        10,
        10000,
        "ms",
        "tilt servo check: failing this long is a jam",
        px4=False,
    ),
    P(
        "CA_FAILURE_MODE",
        INT32,
        1,
        0,
        1,
        "",
        "a detected actuator failure: 0 ignored by the controllers (only reported), 1 the controllers fly without "
        "the motor, with the tilt servo stuck where it was found",
        px4_default=0,
    ),
    P("COM_OF_LOSS_T", REAL32, 1.0, 0.1, 60.0, "s", "offboard set-point loss timeout: then COM_OBL_RC_ACT"),
    P(
        "COM_OBL_RC_ACT",
        INT32,
        0,
        0,
        5,
        "",
        "offboard loss failsafe: 0 Position, 1 Altitude (with MANUAL_CONTROL "
        "heard in the last COM_RC_LOSS_T; without, Hold), 2 Stabilized (Hold: there is no Stabilized), 3 Return, "
        "4 Land, 5 Hold (PX4's 6 Terminate and 7 Disarm are refused)",
    ),
    P("COM_DL_LOSS_T", INT32, 10, 5, 300, "s", "data-link loss: no ground-station HEARTBEAT for this long"),
    P(
        "NAV_DLL_ACT",
        INT32,
        0,
        0,
        3,
        "",
        "data-link loss failsafe: 0 disabled, 1 Hold, 2 Return, 3 Land (PX4's 5 Terminate and 6 Disarm are refused)",
    ),
    P(
        "COM_RC_IN_MODE",
        INT32,
        3,
        0,
        8,
        "",
        "manual control source: 0 RC only (no RC here: MANUAL_CONTROL ignored), "
        "1 MAVLink only, 2 RC or MAVLink with fallback, 3 RC or MAVLink keep first, 4 disabled, 5-8 priorities",
    ),
    P("COM_RC_LOSS_T", REAL32, 0.5, 0.0, 35.0, "s", "manual control loss: no MANUAL_CONTROL for this long"),
    P(
        "NAV_RCL_ACT",
        INT32,
        2,
        0,
        6,
        "",
        "manual control loss failsafe (Position, Altitude): 0 disabled, 1 Hold, "
        "2 Return, 3 Land, 5 Terminate, 6 Disarm (motors off)",
    ),
    P("MPC_VEL_MANUAL", REAL32, 10.0, 3.0, 20.0, "m/s", "Position: horizontal speed at full stick"),
    P("MPC_HOLD_DZ", REAL32, 0.1, 0.0, 1.0, "", "stick deadzone of Position and Altitude (centred: hold)"),
    P(
        "MPC_MAN_Y_MAX",
        REAL32,
        150.0,
        0.0,
        400.0,
        "deg/s",
        "yaw stick: yaw rate at full stick (Position, Altitude, Orbit with yaw behaviour 4)",
    ),
    P(
        "MPC_YAWRAUTO_MAX",
        REAL32,
        30.0,
        5.0,
        360.0,
        "deg/s",
        "fastest turn to a yaw set-point (Offboard, Mission, Go-to, Orbit)",
        px4_default=45.0,
    ),
    P(
        "MIS_YAW_ERR",
        REAL32,
        12.0,
        1.0,
        90.0,
        "deg",
        "a mission waypoint with a yaw (param4) is reached once the "
        "heading is within this of it (flown as a multicopter)",
    ),
    P(
        "MIS_YAW_TMT",
        REAL32,
        -1.0,
        -1.0,
        20.0,
        "s",
        "mission yaw timeout: above 0, a waypoint's yaw is not waited "
        "for (PX4 then waits only for forced headings, which these missions have not); -1 (and 0): wait for "
        "MIS_YAW_ERR. It applies to the Go-to leg too, which waits for its yaw as a waypoint does (PX4's reposition "
        "does not wait)",
    ),
    P("COM_POS_FS_DELAY", INT32, 1, 1, 100, "s", "position loss failsafe (GPS OFF): Descend after this long"),
    P(
        "GF_ACTION",
        INT32,
        2,
        0,
        5,
        "",
        "geofence breach action: 0 none, 1 warning, 2 Hold, 3 Return, 4 terminate (motors off), 5 Land",
    ),
    P("GF_MAX_HOR_DIST", REAL32, 0.0, 0.0, 10000.0, "m", "geofence: the farthest from home horizontally (0: no limit)"),
    P("GF_MAX_VER_DIST", REAL32, 0.0, 0.0, 10000.0, "m", "geofence: the highest above home (0: no limit)"),
    P("COM_DISARM_LAND", REAL32, 2.0, 0.0, 20.0, "s", "disarm this long after a landing is detected"),
    P(
        "COM_DISARM_PRFLT",
        REAL32,
        10.0,
        -1.0,
        300.0,
        "s",
        "disarm when armed on the ground without taking off for this long (negative: never)",
    ),
    P("COM_MOT_TEST_EN", INT32, 1, 0, 1, "", "1 allows MAV_CMD_DO_MOTOR_TEST and MAV_CMD_ACTUATOR_TEST while disarmed"),
    P("MIS_TAKEOFF_ALT", REAL32, 2.5, 1.0, 1000.0, "m", "takeoff altitude above home"),
    P("MPC_TKO_SPEED", REAL32, 1.5, 0.5, 5.0, "m/s", "takeoff climb speed"),
    P("MPC_Z_VEL_MAX_UP", REAL32, 3.0, 0.5, 8.0, "m/s", "fastest climb when holding or returning to an altitude"),
    P("MPC_Z_VEL_MAX_DN", REAL32, 1.5, 0.5, 4.0, "m/s", "fastest descent (landing above MPC_LAND_ALT2)"),
    P("MPC_LAND_SPEED", REAL32, 0.7, 0.2, 3.0, "m/s", "landing descent speed below MPC_LAND_ALT2"),
    P("MPC_LAND_ALT2", REAL32, 5.0, 0.0, 100.0, "m", "below this height above home land at MPC_LAND_SPEED"),
    P("MPC_XY_CRUISE", REAL32, 5.0, 0.5, 12.0, "m/s", "fastest horizontal speed when returning to a hold point"),
    P(
        "MPC_XY_VEL_MAX",
        REAL32,
        12.0,
        1.0,
        30.0,
        "m/s",
        "fastest horizontal speed flying to an Offboard position set-point or in Follow Me",
    ),
    P(
        "MPC_ACC_HOR",
        REAL32,
        2.0,
        0.5,
        10.0,
        "m/s^2",
        "acceleration of the velocity set-points that fly to an Offboard position set-point",
        px4_default=3.0,
    ),
    P("MPC_XY_P", REAL32, 0.95, 0.0, 2.0, "1/s", "horizontal position gain (Hold, Takeoff, Land, Offboard position)"),
    P("MPC_Z_P", REAL32, 1.0, 0.0, 2.0, "1/s", "vertical position gain (Hold, Takeoff)"),
    P(
        "VT_ARSP_BLEND",
        REAL32,
        13.5,
        5.0,
        40.0,
        "m/s",
        "PID baseline: airspeed where MC/FW blending starts",
        px4_default=8.0,
    ),
    P(
        "VT_ARSP_TRANS",
        REAL32,
        23.0,
        5.0,
        40.0,
        "m/s",
        "PID baseline: airspeed where the transition completes",
        px4_default=10.0,
    ),
    P(
        "FW_AIRSPD_TRIM",
        REAL32,
        26.0,
        21.0,
        30.0,
        "m/s",
        "cruise speed of the fixed-wing Hold (loiter) after a transition to fixed wing",
        px4_default=15.0,
    ),
    P(
        "NAV_ACC_RAD",
        REAL32,
        10.0,
        0.05,
        200.0,
        "m",
        "mission waypoint acceptance radius (when the item's param2 is 0)",
    ),
    P(
        "RTL_TYPE",
        INT32,
        0,
        0,
        1,
        "",
        "Return's destination: 0 the closest of home and the rally points; 1 the "
        "closest of the rally points and the mission's landing (the land item after its DO_LAND_START), home only "
        "when there is neither; a mission landing is flown from its DO_LAND_START item (PX4's 2, the mission path, "
        "and 3 are refused)",
    ),
    P(
        "RTL_RETURN_ALT",
        REAL32,
        60.0,
        0.0,
        1000.0,
        "m",
        "Return: climb to this height above home (if lower) before flying to its destination",
    ),
    P(
        "RTL_CONE_ANG",
        INT32,
        45,
        0,
        90,
        "deg",
        "Return: half-angle of the cone over the destination that lowers the "
        "return altitude within RTL_MIN_DIST of it (0: always RTL_RETURN_ALT)",
    ),
    P(
        "RTL_MIN_DIST",
        REAL32,
        10.0,
        0.5,
        10000.0,
        "m",
        "Return: within this horizontal distance of the destination the return altitude is the RTL_CONE_ANG cone's",
    ),
    P(
        "RTL_DESCEND_ALT",
        REAL32,
        30.0,
        0.0,
        1000.0,
        "m",
        "Return: with RTL_LAND_DELAY not 0, descend over the "
        "destination to this height above home (if lower) and wait there before landing",
    ),
    P(
        "RTL_LAND_DELAY",
        REAL32,
        0.0,
        -1.0,
        3600.0,
        "s",
        "Return: wait this long at RTL_DESCEND_ALT before landing (0: land at once; -1: wait for ever, no landing)",
    ),
    P("NAV_LOITER_RAD", REAL32, 250.0, 100.0, 2000.0, "m", "radius of the fixed-wing Hold circle", px4_default=80.0),
    P(
        "SDLOG_MODE",
        INT32,
        0,
        0,
        2,
        "",
        "logging mode: 0 a ULog from arming to disarming, 1 from the start until the first disarming (then as 0), "
        "2 from the start until the autopilot stops (at the next start)",
        reboot_required=True,
    ),
    # Calibration (MAV_CMD_PREFLIGHT_CALIBRATION, docs/mavlink.md#calibration): PX4's names; the ids are PX4 SITL's
    # simulated IMU and magnetometer, which PX4's SITL start-up sets as defaults.
    P("CAL_GYRO0_ID", INT32, 1310988, 0, 2**31 - 1, "", "device id of gyro 0 (the simulated IMU)", px4_default=0),
    P("CAL_GYRO0_XOFF", REAL32, 0.0, -10.0, 10.0, "rad/s", "gyro 0 X-axis offset (gyro calibration; HIGHRES_IMU)"),
    P("CAL_GYRO0_YOFF", REAL32, 0.0, -10.0, 10.0, "rad/s", "gyro 0 Y-axis offset (gyro calibration; HIGHRES_IMU)"),
    P("CAL_GYRO0_ZOFF", REAL32, 0.0, -10.0, 10.0, "rad/s", "gyro 0 Z-axis offset (gyro calibration; HIGHRES_IMU)"),
    P(
        "CAL_ACC0_ID",
        INT32,
        1310988,
        0,
        2**31 - 1,
        "",
        "device id of accelerometer 0 (the simulated IMU)",
        px4_default=0,
    ),
    P("CAL_MAG0_ID", INT32, 197388, 0, 2**31 - 1, "", "device id of magnetometer 0 (the simulated one)", px4_default=0),
    P("SENS_BOARD_X_OFF", REAL32, 0.0, -45.0, 45.0, "deg", "board roll offset (level horizon calibration)"),
    P("SENS_BOARD_Y_OFF", REAL32, 0.0, -45.0, 45.0, "deg", "board pitch offset (level horizon calibration)"),
    # The attitude loop (autopilot/control/attitude.py), both controllers' and the MPC's model of it.
    P(
        "MC_ROLL_P",
        REAL32,
        6.0,
        0.5,
        12.0,
        "1/s",
        "roll attitude gain: roll error -> roll rate set-point",
        px4_default=6.5,
    ),
    P(
        "MC_PITCH_P",
        REAL32,
        6.0,
        0.5,
        12.0,
        "1/s",
        "pitch attitude gain: pitch error -> pitch rate set-point",
        px4_default=6.5,
    ),
    P("MC_YAW_P", REAL32, 3.0, 0.5, 5.0, "1/s", "yaw attitude gain: yaw error -> yaw rate set-point", px4_default=2.8),
    P(
        "MC_ROLLRATE_P",
        REAL32,
        20.0,
        2.0,
        80.0,
        "1/s",
        "roll rate gain: rate error -> angular acceleration (not PX4's normalised torque: PX4's values, 0.01..0.5, "
        "are refused)",
        px4_default=0.15,
        px4_unit="normalised torque per rad/s",
    ),
    P(
        "MC_PITCHRATE_P",
        REAL32,
        20.0,
        2.0,
        80.0,
        "1/s",
        "pitch rate gain: rate error -> angular acceleration (not PX4's normalised torque)",
        px4_default=0.15,
        px4_unit="normalised torque per rad/s",
    ),
    P(
        "MC_YAWRATE_P",
        REAL32,
        10.0,
        1.0,
        40.0,
        "1/s",
        "yaw rate gain: rate error -> angular acceleration (not PX4's normalised torque)",
        px4_default=0.2,
        px4_unit="normalised torque per rad/s",
    ),
    P(
        "MC_ROLLRATE_D",
        REAL32,
        2.0,
        0.0,
        10.0,
        "",
        "roll rate damping on the rate's change between two attitude ticks (4 ms; PX4's is in seconds)",
        px4_default=0.003,
        px4_unit="s",
    ),
    P(
        "MC_PITCHRATE_D",
        REAL32,
        2.0,
        0.0,
        10.0,
        "",
        "pitch rate damping on the rate's change between two attitude ticks (4 ms; PX4's is in seconds)",
        px4_default=0.003,
        px4_unit="s",
    ),
    P(
        "MC_YAWRATE_D",
        REAL32,
        1.0,
        0.0,
        10.0,
        "",
        "yaw rate damping on the rate's change between two attitude ticks (4 ms; PX4's is in seconds)",
        px4_default=0.0,
        px4_unit="s",
    ),
    # The PID baseline (autopilot/control/pid_baseline.py).
    P("MPC_XY_VEL_P_ACC", REAL32, 1.8, 1.2, 5.0, "1/s", "PID baseline: horizontal velocity error -> acceleration"),
    P("MPC_XY_VEL_I_ACC", REAL32, 0.4, 0.0, 60.0, "1/s^2", "PID baseline: horizontal velocity integral gain"),
    P("MPC_Z_VEL_P_ACC", REAL32, 4.0, 2.0, 15.0, "1/s", "PID baseline: vertical velocity error -> acceleration"),
    P("MPC_Z_VEL_I_ACC", REAL32, 2.0, 0.2, 3.0, "1/s^2", "PID baseline: vertical velocity integral gain"),
    P(
        "MPC_TILTMAX_AIR",
        REAL32,
        35.0,
        20.0,
        89.0,
        "deg",
        "PID baseline: the most a multicopter phase tilts",
        px4_default=45.0,
    ),
    P(
        "MPC_ACC_HOR_MAX",
        REAL32,
        6.0,
        2.0,
        15.0,
        "m/s^2",
        "PID baseline: the largest horizontal acceleration",
        px4_default=5.0,
    ),
    P(
        "MPC_ACC_UP_MAX",
        REAL32,
        6.0,
        1.0,
        15.0,
        "m/s^2",
        "PID baseline: the largest upward acceleration",
        px4_default=4.0,
    ),
    P(
        "MPC_ACC_DOWN_MAX",
        REAL32,
        4.0,
        1.0,
        15.0,
        "m/s^2",
        "PID baseline: the largest downward acceleration",
        px4_default=3.0,
    ),
    P(
        "MC_YAWRATE_MAX",
        REAL32,
        45.0,
        5.0,
        1800.0,
        "deg/s",
        "PID baseline: the fastest a yaw reference turns the nose",
        px4_default=200.0,
    ),
    P(
        "VT_TILT_TRANS",
        REAL32,
        1 / 3,
        0.1,
        1.0,
        "",
        "PID baseline: rotor tilt during the forward transition, 1 = 90 deg",
        px4_default=0.4,
    ),
    P("VT_B_DEC_MSS", REAL32, 2.0, 0.5, 10.0, "m/s^2", "PID baseline: deceleration of the back transition"),
    P(
        "FW_AIRSPD_MIN",
        REAL32,
        20.0,
        10.0,
        40.0,
        "m/s",
        "PID baseline: a set-point slower than this ends fixed-wing flight (back transition)",
        px4_default=10.0,
    ),
    P("FW_R_LIM", REAL32, 35.0, 35.0, 70.0, "deg", "PID baseline: the largest fixed-wing bank", px4_default=50.0),
    P("FW_P_LIM_MAX", REAL32, 20.0, 0.0, 60.0, "deg", "PID baseline: the largest fixed-wing pitch", px4_default=30.0),
    P(
        "VT_FW_SPD_P",
        REAL32,
        1.0,
        0.0,
        10.0,
        "1/s",
        "PID baseline, fixed wing: airspeed error -> along-track acceleration",
        px4=False,
    ),
    P("VT_FW_SPD_I", REAL32, 0.3, 0.0, 10.0, "1/s^2", "PID baseline, fixed wing: airspeed integral gain", px4=False),
    P(
        "VT_FW_CLMB_P",
        REAL32,
        0.08,
        0.0,
        1.0,
        "rad s/m",
        "PID baseline, fixed wing: sink-rate error -> pitch",
        px4=False,
    ),
    P("VT_FW_CLMB_I", REAL32, 0.05, 0.0, 1.0, "rad/m", "PID baseline, fixed wing: sink-rate integral gain", px4=False),
    P("VT_FW_CRS_P", REAL32, 0.8, 0.0, 5.0, "1/s", "PID baseline, fixed wing: course error -> turn rate", px4=False),
    # The unified MPC's weights (paper Table 2) and limits (autopilot/mpc/tuning.py).
    P("VT_MPC_Q_VN", REAL32, 20.0, 0.0, 10000.0, "", "MPC weight: north velocity error", px4=False),
    P("VT_MPC_Q_VE", REAL32, 10.0, 0.0, 10000.0, "", "MPC weight: east velocity error", px4=False),
    P("VT_MPC_Q_VD", REAL32, 50.0, 0.0, 10000.0, "", "MPC weight: down velocity error", px4=False),
    P(
        "VT_MPC_QF_VN",
        REAL32,
        20.0,
        0.0,
        10000.0,
        "",
        "MPC weight: north velocity error at the horizon's end",
        px4=False,
    ),
    P(
        "VT_MPC_QF_VE",
        REAL32,
        10.0,
        0.0,
        10000.0,
        "",
        "MPC weight: east velocity error at the horizon's end",
        px4=False,
    ),
    P(
        "VT_MPC_QF_VD",
        REAL32,
        50.0,
        0.0,
        10000.0,
        "",
        "MPC weight: down velocity error at the horizon's end",
        px4=False,
    ),
    P("VT_MPC_Q_ROLL", REAL32, 10.0, 0.0, 10000.0, "", "MPC weight: roll away from the turn's bank", px4=False),
    P("VT_MPC_Q_PITCH", REAL32, 20.0, 0.0, 10000.0, "", "MPC weight: pitch", px4=False),
    P("VT_MPC_Q_YAW", REAL32, 10.0, 0.0, 10000.0, "", "MPC weight: yaw away from its reference", px4=False),
    P("VT_MPC_Q_ROLLR", REAL32, 3.0, 0.0, 10000.0, "", "MPC weight: roll rate", px4=False),
    P("VT_MPC_Q_PITCHR", REAL32, 3.0, 0.0, 10000.0, "", "MPC weight: pitch rate", px4=False),
    P("VT_MPC_Q_YAWR", REAL32, 3.0, 0.0, 10000.0, "", "MPC weight: yaw rate away from the turn's", px4=False),
    P("VT_MPC_R_THR", REAL32, 0.0025, 0.0, 10.0, "1/N^2", "MPC weight: rotor thrust (least effort)", px4=False),
    P(
        "VT_MPC_R_LIFT",
        REAL32,
        0.25,
        0.0,
        100.0,
        "1/N^2",
        "MPC weight: each rotor's lifting thrust beyond the share the wing cannot carry",
        px4=False,
    ),
    P("VT_MPC_R_TILTR", REAL32, 1.0, 0.0, 10000.0, "", "MPC weight: rotor tilt rate", px4=False),
    P(
        "VT_MPC_Q_MOM",
        REAL32,
        1000.0,
        0.0,
        1e6,
        "1/(N m)^2",
        "MPC weight, with a rotor failed: the planned rotors' moment beyond half of what the surfaces can cancel",
        px4=False,
    ),
    P(
        "VT_MPC_Q_MOM_SRV",
        REAL32,
        0.0,
        0.0,
        1e6,
        "1/(N m)^2",
        "MPC weight, with a tilt servo jammed: the planned rotors' moment beyond half of what the surfaces can cancel",
        px4=False,
    ),
    P(
        "VT_MPC_QV_FAIL",
        REAL32,
        6.0,
        1.0,
        100.0,
        "",
        "MPC factor on the north and east velocity weights (Q, QF) while a rotor has failed",
        px4=False,
    ),
    P(
        "VT_MPC_R_ROLLSP",
        REAL32,
        10.0,
        0.0,
        10000.0,
        "",
        "MPC weight: roll set-point away from the turn's bank",
        px4=False,
    ),
    P("VT_MPC_R_PTCHSP", REAL32, 20.0, 0.0, 10000.0, "", "MPC weight: pitch set-point", px4=False),
    P("VT_MPC_R_YAWSP", REAL32, 10.0, 0.0, 10000.0, "", "MPC weight: yaw set-point away from its reference", px4=False),
    P("VT_MPC_ATT_MAX", REAL32, 45.0, 10.0, 80.0, "deg", "MPC limit: roll and pitch (a soft bound)", px4=False),
    P("VT_MPC_ATTSP_MAX", REAL32, 60.0, 10.0, 85.0, "deg", "MPC limit: roll and pitch set-points", px4=False),
    P("VT_MPC_VXY_MAX", REAL32, 30.0, 5.0, 60.0, "m/s", "MPC limit: north and east velocity", px4=False),
    P("VT_MPC_VZ_MAX", REAL32, 10.0, 1.0, 20.0, "m/s", "MPC limit: vertical velocity", px4=False),
    P("VT_MPC_TILTR_MAX", REAL32, 45.0, 5.0, 90.0, "deg/s", "MPC limit: rotor tilt rate", px4=False),
    # The simulated battery and its failsafe (autopilot/commander/battery_simulator.py, docs/failsafes.md).
    P(
        "SIM_BAT_DRAIN",
        REAL32,
        60.0,
        1.0,
        86400.0,
        "s",
        "simulated battery: time to drain from full to empty while armed (full again when disarmed)",
    ),
    P("SIM_BAT_MIN_PCT", REAL32, 50.0, 0.0, 100.0, "%", "simulated battery: the charge never drains below this"),
    P("BAT_LOW_THR", REAL32, 0.15, 0.12, 0.5, "", "low battery: state of charge below this (a warning)"),
    P("BAT_CRIT_THR", REAL32, 0.07, 0.05, 0.25, "", "critical battery: state of charge below this (COM_LOW_BAT_ACT)"),
    P(
        "BAT_EMERGEN_THR",
        REAL32,
        0.05,
        0.03,
        0.1,
        "",
        "emergency battery: state of charge below this (COM_LOW_BAT_ACT)",
    ),
    P(
        "COM_LOW_BAT_ACT",
        INT32,
        0,
        0,
        3,
        "",
        "battery failsafe at the critical and emergency levels: 0 warning, 1 Return, 2 Land, 3 Return at critical "
        "and Land at emergency",
    ),
    # Follow Me (AUTO.FOLLOW_TARGET, docs/follow-me.md): PX4's AutoFollowTarget flight task's; PX4 has no
    # maximum for the height and the distance, 100 m is its limit for adjusting them with the sticks.
    P("FLW_TGT_HT", REAL32, 8.0, 8.0, 100.0, "m", "Follow Me: height above home (above the target with ALT_M 2)"),
    P("FLW_TGT_DST", REAL32, 8.0, 1.0, 100.0, "m", "Follow Me: horizontal distance to the target"),
    P(
        "FLW_TGT_FA",
        REAL32,
        180.0,
        -180.0,
        180.0,
        "deg",
        "Follow Me: angle from the target's course, clockwise (0 in front, 90 right, 180 behind)",
    ),
    P(
        "FLW_TGT_RS",
        REAL32,
        0.1,
        0.0,
        1.0,
        "",
        "Follow Me: the target estimator's responsiveness (lower: faster to follow the target's messages, less "
        "smoothing; taken as 0.1 below 0.1)",
    ),
    P(
        "FLW_TGT_VG",
        REAL32,
        0.9,
        0.1,
        1.0,
        "",
        "Follow Me: the target estimator's velocity gain relative to FLW_TGT_RS",
    ),
    P(
        "FLW_TGT_ALT_M",
        INT32,
        0,
        0,
        2,
        "",
        "Follow Me altitude: 0 FLW_TGT_HT above home, 1 above the terrain (flat: as 0), 2 above the target's altitude",
    ),
    P(
        "FLW_TGT_MAX_VEL",
        REAL32,
        5.0,
        0.0,
        20.0,
        "m/s",
        "Follow Me: the fastest the vehicle circles the target to a new follow angle",
    ),
    # The plant's (transport/plant_parameters.py): read from the plant, set on it, not kept in the file.
    *(
        P(p.name, p.kind, p.default, p.minimum, p.maximum, p.unit, p.description, px4=p.px4, plant=True)
        for p in PLANT_PARAMETERS
    ),
)
del P
SENSOR_FACTORY_PREFIXES = ("CAL_ACC", "CAL_GYRO", "CAL_MAG")  # what PREFLIGHT_STORAGE param1 3 resets (PX4's)

BY_NAME = {definition.name: definition for definition in DEFINITIONS}


class ParameterFileError(ValueError):
    """The parameter file cannot be used (not JSON, wrong shape, bad value)."""


class ParameterRejected(ValueError):
    """A PARAM_SET that cannot be applied; the message says why."""


def encode_value(definition: ParameterDefinition, value: float) -> float:
    """The float that carries `value` in PARAM_VALUE.param_value (PX4 bytewise encoding for INT32)."""
    return encode_bytewise(definition.kind, value)


def decode_value(definition: ParameterDefinition, param_value: float) -> float:
    """The value a PARAM_SET.param_value carries (PX4 bytewise encoding for INT32)."""
    return decode_bytewise(definition.kind, param_value)


def default_parameter_path(instance: int) -> Path:
    """$XDG_STATE_HOME/tiltrotor-sitl/params-<instance>.json (~/.local/state when XDG_STATE_HOME is unset)."""
    base = os.environ.get("XDG_STATE_HOME") or os.path.join(os.path.expanduser("~"), ".local", "state")
    return Path(base) / "tiltrotor-sitl" / f"params-{instance}.json"


def vehicle_system_id(params: ParameterStore, instance: int) -> int:
    """The vehicle's MAVLink system id as PX4 picks it: MAV_SYS_ID when it was changed from its default, else the
    instance's (instance + 1, transport.ports.Ports.system_id)."""
    if "MAV_SYS_ID" in params.non_default():
        return params.get_int("MAV_SYS_ID")
    return Ports(instance).system_id


def _format_value(definition: ParameterDefinition, value: float) -> str:
    return str(int(value)) if definition.kind == INT32 else f"{value:g}"


class ParameterStore:
    """Values by name, in a fixed order (param_index), persisted to `path` (None: not persisted)."""

    def __init__(self, path: Path | None = None, definitions: tuple[ParameterDefinition, ...] = DEFINITIONS) -> None:
        self.definitions = definitions
        self.index = {d.name: i for i, d in enumerate(definitions)}
        self.values: dict[str, float] = {d.name: float(d.default) for d in definitions}
        self.path = path
        self.version = 0  # counts changes: the flight stack hands changed values on when it sees a new one
        self.warnings: list[str] = []
        self.signing_key: SigningKey | None = None  # MAVLink 2 signing (SETUP_SIGNING), kept in the same file
        self.set_since_start: set[str] = set()  # names changed since the file was loaded (a reboot applies them)
        self._writer = BackgroundWriter(path, "parameter file") if path is not None else None

    # ---- access ------------------------------------------------------------------------------------------
    def __getitem__(self, name: str) -> float:
        return self.values[name]

    def get_int(self, name: str) -> int:
        return int(self.values[name])

    def __len__(self) -> int:
        return len(self.definitions)

    def definition(self, name: str) -> ParameterDefinition | None:
        return BY_NAME.get(name) if name in self.index else None

    # ---- changes -----------------------------------------------------------------------------------------
    def check(self, name: str, value: float) -> ParameterDefinition:
        """Raise ParameterRejected unless `value` is acceptable for `name`."""
        definition = self.definition(name)
        if definition is None:
            raise ParameterRejected(f"unknown parameter {name!r}")
        if not math.isfinite(value):
            raise ParameterRejected(f"{name}: {value} is not a finite number")
        if definition.kind == INT32 and value != int(value):
            raise ParameterRejected(f"{name}: {value} is not an integer")
        if not definition.minimum <= value <= definition.maximum:
            raise ParameterRejected(f"{name}: {_format_value(definition, value)} outside "
                                    f"{_format_value(definition, definition.minimum)}.."
                                    f"{_format_value(definition, definition.maximum)}")  # fmt: skip
        blend = value if name == "VT_ARSP_BLEND" else self.values["VT_ARSP_BLEND"]
        trans = value if name == "VT_ARSP_TRANS" else self.values["VT_ARSP_TRANS"]
        if name in ("VT_ARSP_BLEND", "VT_ARSP_TRANS") and blend >= trans:
            raise ParameterRejected(f"{name}: VT_ARSP_BLEND ({blend:g}) must stay below VT_ARSP_TRANS ({trans:g})")
        return definition

    def set(self, name: str, value: float) -> bool:
        """Set a value (checked); True when it changed. The file is rewritten in the background."""
        definition = self.check(name, value)
        value = float(int(value)) if definition.kind == INT32 else float(value)
        if self.values[name] == value:
            return False
        self.values[name] = value
        self.version += 1
        self.set_since_start.add(name)
        self.save()
        if not definition.plant:
            self.save()
        return True

    def set_signing_key(self, key: SigningKey | None) -> None:
        """Set (None: remove) the signing key; the file is rewritten in the background, atomically as ever."""
        self.signing_key = key
        self.save()

    # ---- persistence -------------------------------------------------------------------------------------
    def non_default(self) -> dict[str, int | float]:
        """The vehicle's parameters that differ from their defaults (the plant's are the plant's to keep)."""
        changed: dict[str, int | float] = {}
        for d in self.definitions:
            if d.plant:
                continue
            value = self.values[d.name]
            if value != float(d.default):
                changed[d.name] = int(value) if d.kind == INT32 else value
        return changed

    def document(self) -> str:
        document: dict[str, Any] = {"format": FILE_FORMAT, "version": FILE_VERSION, "parameters": self.non_default()}
        if self.signing_key is not None:
            document["signing"] = key_to_document(self.signing_key)
        return json.dumps(document, indent=1, sort_keys=True) + "\n"

    def save(self) -> None:
        if self._writer is not None:
            self._writer.submit(self.document())

    @property
    def write_error(self) -> str | None:
        """The last write's error (None: it worked, or nothing was written yet)."""
        return None if self._writer is None else self._writer.last_error

    def flush(self, timeout_s: float = 10.0) -> str | None:
        """Wait for pending writes; returns the last write error (or None)."""
        if self._writer is None:
            return None
        return self._writer.flush(timeout_s)

    def reset(self, prefixes: tuple[str, ...] = ("",)) -> list[str]:
        """Every parameter whose name starts with one of `prefixes` (all by default) back to its default; the names
        that changed. The signing key stays (it is not a parameter)."""
        changed = []
        for definition in self.definitions:
            if definition.name.startswith(prefixes) and self.values[definition.name] != float(definition.default):
                self.values[definition.name] = float(definition.default)
                changed.append(definition.name)
        if changed:
            self.version += 1
            self.set_since_start.update(changed)
        self.save()
        return changed

    def reload(self) -> list[str]:
        """Read the file again (PREFLIGHT_STORAGE's read): what it does not hold goes back to its default; the names
        that changed. ParameterFileError if the file is broken (nothing changed then)."""
        fresh = ParameterStore(self.path, self.definitions)
        fresh.load()
        changed = [name for name, value in fresh.values.items() if self.values[name] != value]
        if changed:
            self.values.update({name: fresh.values[name] for name in changed})
            self.version += 1
            self.set_since_start.update(changed)
        return changed

    def load(self) -> None:
        """Read the file if it exists (a missing file means all defaults); raise ParameterFileError if broken."""
        if self.path is None:
            return
        text = read_kept(self.path, "parameter file", ParameterFileError)
        if text is None:
            return
        where = f"parameter file {self.path}"
        try:
            document = json.loads(text)
        except ValueError as exc:
            raise ParameterFileError(f"{where} is not valid JSON ({exc})") from None
        if not isinstance(document, dict) or document.get("format") != FILE_FORMAT:
            raise ParameterFileError(f'{where}: not a tiltrotor-sitl parameter file (no "format": "{FILE_FORMAT}")')
        if document.get("version") != FILE_VERSION:
            raise ParameterFileError(f"{where}: version {document.get('version')!r}, expected {FILE_VERSION}")
        parameters = document.get("parameters")
        if not isinstance(parameters, dict):
            raise ParameterFileError(f'{where}: "parameters" must be an object of NAME: value')
        loaded: dict[str, float] = {}
        for name, value in parameters.items():
            if name not in self.index:
                self.warnings.append(f"{where}: unknown parameter {name!r} ignored")
                continue
            if BY_NAME[name].plant:
                self.warnings.append(f"{where}: {name} ignored: the plant keeps it (vtol-sim --wind, or PARAM_SET "
                                     f"while it runs)")  # fmt: skip
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ParameterFileError(f"{where}: {name} = {value!r} is not a number")
            try:
                self.check(name, float(value))
            except ParameterRejected as exc:
                raise ParameterFileError(f"{where}: {exc}") from None
            loaded[name] = float(value)
        self.values.update(loaded)
        if "signing" in document:
            try:
                self.signing_key = key_from_document(document["signing"])
            except SigningRefused as exc:
                raise ParameterFileError(f"{where}: {exc}") from None
        if self.values["VT_ARSP_BLEND"] >= self.values["VT_ARSP_TRANS"]:
            raise ParameterFileError(f"{where}: VT_ARSP_BLEND must be below VT_ARSP_TRANS")
