"""Home (docs/mavlink.md, "Commands" (DO_SET_HOME)): PX4 SITL's default, PX4_HOME_LAT/LON/ALT from the environment as PX4 reads them, or
--home; one choice for plant and autopilot; a bad one refused."""

from __future__ import annotations

import math

import pytest
from pymavlink import mavutil

from tiltrotor_sitl import Vehicle
from tiltrotor_sitl._children import run_to_end
from tiltrotor_sitl._commands import AutopilotCommand, SimCommand, Zenoh, free_link_ports
from tiltrotor_sitl._free_ports import free_udp_port
from transport.geodesy import Home


@pytest.mark.parametrize("program", ["autopilot", "sim_bridge"])
def test_a_bad_home_in_the_environment_stops_the_process_with_one_line(program):
    environ = {"PX4_HOME_LAT": "north"}  # over this environment
    ports = free_link_ports()  # (refused before any port is bound, but a port in use must not be what stops it)
    command = (
        SimCommand(port=free_udp_port(), zenoh=Zenoh.off())
        if program == "sim_bridge"
        else AutopilotCommand(sim_port=free_udp_port(), links=ports, zenoh=Zenoh.off())
    )
    result = run_to_end(command.argv(), timeout_s=60, env=environ)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "home refused: PX4_HOME_LAT='north' is not a number" in lines[0]


def test_the_vehicle_reports_the_home_px4_home_variables_give(monkeypatch):
    monkeypatch.setenv("PX4_HOME_LAT", "-33.8688")
    monkeypatch.setenv("PX4_HOME_LON", "151.2093")
    monkeypatch.setenv("PX4_HOME_ALT", "58")
    with Vehicle(controller="pid", truth=False, speed=None) as vehicle:
        assert vehicle.home == Home(-33.8688, 151.2093, 58.0)
        link = mavutil.mavlink_connection(vehicle.pymavlink, source_system=250)
        try:
            home = link.recv_match(type="HOME_POSITION", blocking=True, timeout=30)
            position = link.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=30)
        finally:
            link.close()
    assert home is not None and position is not None
    # Home is where the vehicle stands (PX4: its first valid position), its centre of gravity on the gear over
    # the ground at PX4_HOME_ALT.
    assert (home.latitude, home.longitude) == (-338688000, 1512093000)
    assert 58000 < home.altitude < 59000 and abs(home.altitude - position.alt) < 50
    assert abs(home.z + (home.altitude - 58000) / 1000) < 0.01  # its place in the local frame: over the origin
    assert math.hypot(position.lat - home.latitude, position.lon - home.longitude) < 100  # within ~1 m
