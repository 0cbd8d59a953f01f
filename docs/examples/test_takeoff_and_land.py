"""docs/testing.md's worked example: your ground software takes off, climbs to 8 m and lands; the test checks what
the vehicle really did, after the fact. Run it with `pytest` (the tiltrotor-sitl plugin gives `vehicle`)."""

from pymavlink import mavutil

ARMED = mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED


def takeoff_and_land(gcs, altitude_m):  # yours (here with the helpers): returns once landed and disarmed
    gcs.arm()
    gcs.takeoff(altitude_m)
    gcs.wait_message("LOCAL_POSITION_NED", lambda position: -position.z > altitude_m - 0.3, timeout_s=60)
    gcs.land()
    gcs.wait_message("HEARTBEAT", lambda heartbeat: not heartbeat.base_mode & ARMED, timeout_s=120)


def test_takeoff_and_land(vehicle):
    takeoff_and_land(vehicle.ground_station, altitude_m=8.0)
    flight = vehicle.truth.trajectory()  # every sample of the plant's truth since the vehicle was ready
    assert 7.7 < flight.altitude.max() < 8.5
    assert abs(flight.position_ned[:, :2]).max() < 1.0  # straight up and down
    assert flight.on_ground[-1]
