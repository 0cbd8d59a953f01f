"""The public API (tiltrotor_sitl) and its pytest plugin, as a user meets them: a user's own test folder outside
the repository run with `pytest -n 2`, bad input, and children that do not outlive their parent."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from tests.unit.test_api import children_of
from tiltrotor_sitl import ProcessOptions, Vehicle, VehicleError
from transport.ports import Ports

USER_TEST = """
import math
import os
import time

from mavsdk import ComponentType, Configuration, Mavsdk
from mavsdk.plugins.action import Action
from mavsdk.plugins.telemetry import Telemetry
from pymavlink import mavutil

M = mavutil.mavlink


def note_pids(pids):
    with open(os.environ["PIDS_FILE"], "a") as out:
        out.write("".join(f"{pid}\\n" for pid in pids))


def command(master, sysid, cmd, *params):
    params = list(params) + [0.0] * (7 - len(params))
    while master.recv_msg() is not None:  # what piled up while we were not reading
        pass
    master.mav.command_long_send(sysid, 1, cmd, 0, *params)
    while True:
        ack = master.recv_match(type="COMMAND_ACK", blocking=True, timeout=10)
        assert ack is not None, f"no COMMAND_ACK for {cmd}"
        if ack.command == cmd:
            return ack.result


def test_takeoff_and_land(vehicle_factory):
    vehicle = vehicle_factory(params={"MIS_TAKEOFF_ALT": 8.0})
    note_pids(vehicle.pids)
    master = mavutil.mavlink_connection(vehicle.pymavlink, source_system=255, source_component=190)
    assert master.wait_heartbeat(timeout=10).get_srcSystem() == vehicle.sysid
    assert command(master, vehicle.sysid, M.MAV_CMD_COMPONENT_ARM_DISARM, 1) == M.MAV_RESULT_ACCEPTED
    assert command(master, vehicle.sysid, M.MAV_CMD_NAV_TAKEOFF, *[math.nan] * 7) == M.MAV_RESULT_ACCEPTED
    vehicle.truth.wait_until(lambda s: s.altitude > 7.0, timeout_sim_s=40, what="climb to 7 m")
    assert command(master, vehicle.sysid, M.MAV_CMD_NAV_LAND) == M.MAV_RESULT_ACCEPTED
    vehicle.truth.wait_until(lambda s: s.on_ground, timeout_sim_s=60, what="landing")
    master.close()


def test_mavsdk_flies_it_up_and_down(vehicle):
    note_pids(vehicle.pids)
    drone = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    try:
        drone.add_any_connection(vehicle.mavsdk)
        system = drone.first_autopilot(30.0)
        assert system is not None, "MAVSDK found no autopilot"
        action, telemetry = Action(system), Telemetry(system)
        deadline = time.monotonic() + 30
        while not telemetry.health().is_armable:
            assert time.monotonic() < deadline, "not armable"
            time.sleep(0.05)
        action.set_takeoff_altitude(6.0)
        action.arm()
        action.takeoff()
        vehicle.truth.wait_until(lambda s: s.altitude > 5.0, timeout_sim_s=40, what="climb to 5 m")
        action.land()
        vehicle.truth.wait_until(lambda s: s.on_ground, timeout_sim_s=60, what="landing")
    finally:
        drone.destroy()


def test_one_ground_station_sees_the_fleet(fleet_factory):
    with socket_port() as port:
        pass
    ground_station = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}")
    fleet = fleet_factory(3, gcs_port=port)
    note_pids(fleet.pids)
    seen = set()
    while seen != {1, 2, 3}:
        heartbeat = ground_station.recv_match(type="HEARTBEAT", blocking=True, timeout=10)
        assert heartbeat is not None, f"only {sorted(seen)} seen"
        seen.add(heartbeat.get_srcSystem())
    ground_station.close()
    east = [v.truth.latest().position_ned for v in fleet.vehicles]  # each in its own frame, at its own home
    assert all(abs(n) < 0.5 and abs(e) < 0.5 for n, e, _ in east)
    assert fleet.vehicles[1].home.lon > fleet.vehicles[0].home.lon


def socket_port():
    import socket

    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    return _Closing(s)


class _Closing:
    def __init__(self, s):
        self.s = s

    def __enter__(self):
        return self.s.getsockname()[1]

    def __exit__(self, *exc):
        self.s.close()
"""


def alive(pid: int) -> bool:
    """Running (a zombie counts as stopped)."""
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(") ", 1)[1][0] != "Z"
    except OSError:
        return False


def test_a_users_own_tests_pass_under_xdist_and_leave_nothing_running(tmp_path: Path) -> None:
    folder = tmp_path / "user_project"
    folder.mkdir()
    (folder / "test_my_ground_software.py").write_text(USER_TEST)
    pids_file = tmp_path / "pids.txt"
    env = {**os.environ, "PIDS_FILE": str(pids_file)}
    env.pop("PYTEST_ADDOPTS", None)
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-n",
            "2",
            "-q",
            "-p",
            "no:cacheprovider",
            "--vtol-controller",
            "pid",
            "--vtol-speed",
            "2",
        ],  # fmt: skip
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=400,
    )
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-2000:]
    assert "3 passed" in result.stdout
    pids = [int(line) for line in pids_file.read_text().split()]
    assert len(pids) == 2 + 2 + 6
    assert [pid for pid in pids if alive(pid)] == []


def test_children_die_with_a_killed_parent(tmp_path: Path) -> None:
    script = textwrap.dedent("""
        import sys, time
        from tiltrotor_sitl import Vehicle
        v = Vehicle(controller="pid", truth=False).start()
        print(" ".join(map(str, v.pids)), flush=True)
        time.sleep(600)
    """)
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        pids = [int(p) for p in parent.stdout.readline().split()]
        assert len(pids) == 2 and all(alive(pid) for pid in pids)
    finally:
        parent.send_signal(signal.SIGKILL)
        parent.wait()
    deadline = time.monotonic() + 10
    while any(alive(pid) for pid in pids) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert [pid for pid in pids if alive(pid)] == []


def test_a_port_in_use_is_named_and_nothing_starts() -> None:
    instance = 900 + os.getpid() % 90
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as blocker:
        blocker.bind(("127.0.0.1", Ports(instance).plant))
        with pytest.raises(VehicleError, match=f"cannot bind UDP port 127.0.0.1:{Ports(instance).plant} \\(the plant "
                                               "link\\): Address already in use"):  # fmt: skip
            Vehicle(instance=instance).start()
    assert children_of(os.getpid()) == []


def test_a_process_dying_at_start_up_is_quoted(tmp_path: Path) -> None:
    broken = tmp_path / "broken.toml"
    broken.write_text("this is not = = toml\n")
    with pytest.raises(VehicleError, match="exited with code 2 during start-up; its last stderr lines:\n.*broken"):
        Vehicle(airframe=broken, truth=False).start()
    assert children_of(os.getpid()) == []


def test_no_readiness_in_time_is_a_clear_error() -> None:
    with pytest.raises(VehicleError, match="not ready to arm within 0.05 s .*system id 1: no HEARTBEAT"):
        Vehicle(controller="pid", truth=False, processes=ProcessOptions(ready_timeout_s=0.05)).start()
    assert children_of(os.getpid()) == []


def test_a_process_that_dies_before_its_duration_is_quoted() -> None:
    with Vehicle(
        speed=None, truth=False, processes=ProcessOptions(autopilot=False, duration_s=10.0)
    ) as plant:  # alone: nobody steps it
        assert plant.pids == [plant.process("vtol-sim").pid]
        plant.process("vtol-sim").kill()
        with pytest.raises(VehicleError, match="vtol-sim .* exited with code -9 before the end"):
            plant.wait_finished(timeout_s=30)
    assert children_of(os.getpid()) == []
