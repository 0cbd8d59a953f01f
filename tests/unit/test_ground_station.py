"""The ground station helper's pure parts (tiltrotor_sitl/ground_station.py, flight_modes.py): PX4's mode names and
custom modes, the failure names of PX4's `failure` command, PX4's bytewise parameter encoding."""

from __future__ import annotations

import math

import pytest

from tiltrotor_sitl import FlightMode
from tiltrotor_sitl.ground_station import decode_parameter, encode_parameter, failure_params
from transport.mavlink import mavlink as M


@pytest.mark.parametrize("name, mode, custom_mode", [
    ("HOLD", FlightMode.HOLD, (4 << 16) | (3 << 24)),
    ("Hold", FlightMode.HOLD, (4 << 16) | (3 << 24)),
    ("AUTO.LOITER", FlightMode.HOLD, (4 << 16) | (3 << 24)),
    ("offboard", FlightMode.OFFBOARD, 6 << 16),
    ("MISSION", FlightMode.MISSION, (4 << 16) | (4 << 24)),
    ("RTL", FlightMode.RETURN, (4 << 16) | (5 << 24)),
    ("Return", FlightMode.RETURN, (4 << 16) | (5 << 24)),
    ("takeoff", FlightMode.TAKEOFF, (4 << 16) | (2 << 24)),
    ("LAND", FlightMode.LAND, (4 << 16) | (6 << 24)),
    ("Position", FlightMode.POSCTL, 3 << 16),
    ("ALTCTL", FlightMode.ALTCTL, 2 << 16),
    ("orbit", FlightMode.ORBIT, (3 << 16) | (1 << 24)),
])  # fmt: skip
def test_px4_mode_names_and_their_custom_modes(name: str, mode: FlightMode, custom_mode: int) -> None:
    assert FlightMode.named(name) is mode
    assert mode.custom_mode == custom_mode
    assert FlightMode.of_custom_mode(custom_mode) is mode
    assert mode == mode.value  # a str: compared and printed by its name


def test_offboard_is_recognised_whatever_its_sub_mode_and_unknown_names_are_refused() -> None:
    assert FlightMode.of_custom_mode((6 << 16) | (3 << 24)) is FlightMode.OFFBOARD
    assert FlightMode.of_custom_mode(42 << 16) is None
    with pytest.raises(ValueError, match="unknown flight mode 'GUIDED': PX4's modes are MANUAL, .*HOLD"):
        FlightMode.named("GUIDED")


def test_failures_by_px4_names() -> None:
    assert failure_params("motor", "off", 1, math.nan)[:3] == (101.0, 1.0, 1.0)
    assert failure_params("Servo", "STUCK", 2, 60.0) == (102.0, 2.0, 2.0, 60.0)
    assert failure_params("gps", "off", 0, math.nan)[:3] == (4.0, 1.0, 0.0)
    with pytest.raises(ValueError, match="failure unit 'rotor': one of gyro, accel, mag, baro, gps, airspeed, motor"):
        failure_params("rotor", "off", 1, math.nan)
    with pytest.raises(ValueError, match="failure type 'garbage': one of ok, off, stuck, wrong"):
        failure_params("motor", "garbage", 1, math.nan)
    with pytest.raises(ValueError, match="motor instance 5 not in 0..4"):
        failure_params("motor", "off", 5, math.nan)


def test_parameters_travel_as_px4_encodes_them() -> None:
    assert decode_parameter(encode_parameter(1, M.MAV_PARAM_TYPE_INT32), M.MAV_PARAM_TYPE_INT32) == 1.0
    assert decode_parameter(encode_parameter(-42, M.MAV_PARAM_TYPE_INT32), M.MAV_PARAM_TYPE_INT32) == -42.0
    assert encode_parameter(1, M.MAV_PARAM_TYPE_INT32) != 1.0  # bytewise: 1 as int32 bits is a tiny float
    assert encode_parameter(2.5, M.MAV_PARAM_TYPE_REAL32) == 2.5
    assert decode_parameter(2.5, M.MAV_PARAM_TYPE_REAL32) == 2.5
