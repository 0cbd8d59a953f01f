"""Arm, take off to 10 m, fly north at 3 m/s for 5 s in OFFBOARD, land: a pymavlink ground station.

Start the vehicle first (another terminal):  vtol up            (or: vtol up --speed 4, four times real time)
Then:                                        python pymavlink_offboard.py [CONNECTION]

CONNECTION: where to listen for the vehicle's GCS link, by default udpin:127.0.0.1:14550 (every instance sends there).
"""

import math
import sys
import time

from pymavlink import mavutil

CONNECTION = sys.argv[1] if len(sys.argv) > 1 else "udpin:127.0.0.1:14550"  # where the GCS link sends
HOLD, OFFBOARD = (4 << 16) | (3 << 24), 6 << 16  # PX4 custom modes: AUTO.LOITER and OFFBOARD
VELOCITY_ONLY = 0b0000_1001_1100_0111  # type_mask: ignore position, acceleration and yaw rate (as MAVSDK)

vehicle = mavutil.mavlink_connection(CONNECTION, source_system=255, source_component=190)
heartbeat = vehicle.wait_heartbeat()
print(
    f"heartbeat from {heartbeat.get_srcSystem()}/{heartbeat.get_srcComponent()}: type {heartbeat.type} "
    f"(VTOL tiltrotor), autopilot {heartbeat.autopilot} (PX4), mode {vehicle.flightmode}"
)
vehicle.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
sim_ms = 0  # the vehicle's clock (simulation time) from its telemetry


def pump(seconds=0.05):
    """Read telemetry for a while (wall time); keep the latest message of each type."""
    global sim_ms
    end = time.monotonic() + seconds
    while (message := vehicle.recv_match(blocking=True, timeout=max(0.001, end - time.monotonic()))) is not None:
        latest[message.get_type()] = message
        sim_ms = getattr(message, "time_boot_ms", sim_ms)
        if message.get_type() == "STATUSTEXT":
            print(f"  [{sim_ms / 1000:6.2f} s] vehicle says: {message.text}")
        if time.monotonic() >= end:
            break


def command(command_id, *params):
    """COMMAND_LONG to the autopilot (1/1), then its COMMAND_ACK result."""
    latest.pop("COMMAND_ACK", None)
    vehicle.mav.command_long_send(1, 1, command_id, 0, *(list(params) + [0] * (7 - len(params))))
    while "COMMAND_ACK" not in latest or latest["COMMAND_ACK"].command != command_id:
        pump()
    return latest["COMMAND_ACK"].result


def wait_until(condition, every=None):
    while not condition():
        if every:
            every()
        pump()


latest = {}
wait_until(lambda: {"LOCAL_POSITION_NED", "HEARTBEAT", "HOME_POSITION"} <= latest.keys())
altitude = lambda: -latest["LOCAL_POSITION_NED"].z  # noqa: E731
armed = lambda: latest["HEARTBEAT"].base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED  # noqa: E731

print("arm:", command(mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1))
home = latest["HOME_POSITION"].altitude / 1000  # m AMSL
print("takeoff:", command(mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, home + 10))
wait_until(lambda: latest["HEARTBEAT"].custom_mode == HOLD and altitude() > 9.5)
print(f"holding at {altitude():.2f} m, mode {vehicle.flightmode}")


def north():  # a velocity set-point, stamped with the vehicle's clock
    vehicle.mav.set_position_target_local_ned_send(
        sim_ms, 1, 1, mavutil.mavlink.MAV_FRAME_LOCAL_NED, VELOCITY_ONLY, 0, 0, 0, 3.0, 0, 0, 0, 0, 0, 0, 0
    )


north()  # Offboard needs a set-point first
pump()
print("offboard:", command(mavutil.mavlink.MAV_CMD_DO_SET_MODE, 1, 6, 0))
start = sim_ms
wait_until(lambda: sim_ms - start >= 5000, every=north)
p = latest["LOCAL_POSITION_NED"]
print(f"after 5 s in {vehicle.flightmode}: {p.x:.1f} m north, vn {p.vx:.2f} m/s, altitude {-p.z:.2f} m")
print("hold:", command(mavutil.mavlink.MAV_CMD_DO_SET_MODE, 1, 4, 3))
print("land:", command(mavutil.mavlink.MAV_CMD_NAV_LAND))
wait_until(lambda: not armed())
print(f"landed and disarmed at {altitude():.2f} m, t = {sim_ms / 1000:.1f} s (simulated)")
