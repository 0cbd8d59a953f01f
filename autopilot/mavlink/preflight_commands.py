"""The preflight commands, read into requests (autopilot/commander/flight_stack.py judges them, disarmed only):
MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, MAV_CMD_PREFLIGHT_STORAGE and MAV_CMD_PREFLIGHT_CALIBRATION, with PX4's
parameters. Each function gives the request, or the reply that answers the command itself."""

from __future__ import annotations

from autopilot.mavlink.command_params import Params, int_param
from autopilot.topics.requests import Calibrate, PreflightStorage, Reboot, Reply
from transport.mavlink import mavlink as M

NOT_SIMULATED = (M.MAV_RESULT_UNSUPPORTED, "{} calibration: not simulated (gyro, level, accel and mag are)")


def reboot_shutdown(p: Params) -> Reboot | Reply:
    """param1 (the autopilot): 0 nothing (ACCEPTED, as PX4), 1 reboot; 2 shutdown and 3 reboot into the bootloader
    are DENIED, as PX4's SITL denies them (it has no power control and no bootloader). The other params (onboard
    computer, camera...) are not this component's, as in PX4."""
    action = int_param(p[0])
    if action == 0:
        return M.MAV_RESULT_ACCEPTED, None
    if action == 1:
        return Reboot()
    if action == 2:
        return M.MAV_RESULT_DENIED, "Shutdown denied: a simulated autopilot has no power control"
    if action == 3:
        return M.MAV_RESULT_DENIED, "Reboot to bootloader denied: a simulated autopilot has no bootloader"
    return M.MAV_RESULT_DENIED, f"Reboot/shutdown: param1 {p[0]:g} is not 0..3"


def preflight_storage(p: Params) -> PreflightStorage | Reply:
    """param1 PREFLIGHT_STORAGE_PARAMETER_ACTION 0..4 (PreflightStorage); param2 (missions) is not read, as PX4
    does not read it: the missions are kept in their own file whenever they change."""
    action = int_param(p[0])
    if action is None or not 0 <= action <= 4:
        return M.MAV_RESULT_DENIED, f"Preflight storage: param1 {p[0]:g} is not 0..4"
    return PreflightStorage(action)


def preflight_calibration(p: Params) -> Calibrate | Reply:
    """PX4's reading of the params, first match wins: param1 1 gyro; param2 1 magnetometer; param5 1 accelerometer,
    2 level horizon; every param 0 cancels. Temperature (3 in param1, 5 or 7), barometer (param3 1), RC (param4 1
    or 2), quick accelerometer (param5 4), airspeed (param6 1 or 2) and ESC (param7 1) are UNSUPPORTED here."""
    if p[0] == 1:
        return Calibrate("gyro")
    if 3 in (p[0], p[4], p[6]):
        return NOT_SIMULATED[0], NOT_SIMULATED[1].format("Temperature")
    if p[1] == 1:
        return Calibrate("mag")
    for value, name in ((p[2] == 1, "Baro"), (p[3] in (1, 2), "RC")):
        if value:
            return NOT_SIMULATED[0], NOT_SIMULATED[1].format(name)
    if p[4] == 1:
        return Calibrate("accel")
    if p[4] == 2:
        return Calibrate("level")
    for value, name in ((p[4] == 4, "Quick accel"), (p[5] in (1, 2), "Airspeed"), (p[6] == 1, "ESC")):
        if value:
            return NOT_SIMULATED[0], NOT_SIMULATED[1].format(name)
    if all(value == 0 for value in p[:6]):
        return Calibrate(None)
    return M.MAV_RESULT_UNSUPPORTED, "Calibration: no sensor named in params 1..7"
