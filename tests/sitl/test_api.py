"""The public API (tiltrotor_sitl) and its pytest plugin, as a user meets them: a user's own test folder outside
the repository run with `pytest -n 2` (docs/testing.md's worked example among its tests), a failing test's report
with the vehicle's logs, bad input, and children that do not outlive their parent."""

from __future__ import annotations

import os
import re
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
import os
import time

from mavsdk import ComponentType, Configuration, Mavsdk
from mavsdk.plugins.action import Action
from mavsdk.plugins.telemetry import Telemetry
from pymavlink import mavutil


def note_pids(pids):
    with open(os.environ["PIDS_FILE"], "a") as out:
        out.write("".join(f"{pid}\\n" for pid in pids))


def test_mavsdk_flies_it_up_and_down(vehicle):
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
# Records the PIDs of the `vehicle` a test used (docs/testing.md's example does not know of this test).
USER_CONFTEST = """
import os

import pytest


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_teardown(item):
    vehicle = item.funcargs.get("vehicle")
    if vehicle is not None:
        with open(os.environ["PIDS_FILE"], "a") as out:
            out.write("".join(f"{pid}\\n" for pid in vehicle.pids))
"""
EXAMPLE = Path(__file__).parents[2] / "docs" / "examples" / "test_takeoff_and_land.py"


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
    (folder / "test_takeoff_and_land.py").write_text(EXAMPLE.read_text())
    (folder / "conftest.py").write_text(USER_CONFTEST)
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
            "--vtol-keep-logs",
            "--basetemp",
            str(tmp_path / "base"),
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
    # --vtol-keep-logs: the passing tests' vehicle folders are kept under their tmp_path, with the .tlog
    kept = sorted(path.relative_to(tmp_path / "base") for path in (tmp_path / "base").rglob("vtol-autopilot.stderr"))
    assert len(kept) == 1 + 1 + 3, kept
    (example,) = (tmp_path / "base").rglob("test_takeoff_and_land0")
    assert (example / "vtol-0" / "gcs.tlog").stat().st_size > 10_000


FAILING_TESTS = """
def test_fails_on_purpose(vehicle):
    gcs = vehicle.ground_station
    gcs.arm()
    gcs.takeoff(5.0)
    vehicle.truth.wait_until(lambda s: s.altitude > 4.5, timeout_sim_s=40)
    assert vehicle.truth.latest().altitude > 100, "on purpose"


def test_fails_without_the_ground_station(vehicle):
    assert not vehicle.truth.latest().on_ground, "on purpose"


def test_passes(vehicle):
    assert vehicle.ground_station.mode == "HOLD"
"""


def report_sections(output: str) -> dict[str, str]:
    """pytest's report sections of the failing tests, by their header's name ("vtol vehicle 1 (call)" ...)."""
    sections, name = {}, None
    for line in output.splitlines():
        header = re.fullmatch(r"-+ (.+?) -+", line)
        if header:
            name = header.group(1)
            sections[name] = ""
        elif re.fullmatch(r"_+ (test_\w+) _+", line):
            name = None
            sections[line.strip("_ ")] = ""
        elif name is not None:
            sections[name] += line + "\n"
    return sections


def test_a_failing_test_reports_its_vehicles_logs_and_status_and_keeps_them(tmp_path: Path) -> None:
    folder, base = tmp_path / "user_project", tmp_path / "base"
    folder.mkdir()
    (folder / "test_fails.py").write_text(FAILING_TESTS)
    env = {key: value for key, value in os.environ.items() if key != "PYTEST_ADDOPTS"}
    result = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "--vtol-speed", "2",
                             "--basetemp", str(base)], cwd=folder, env=env, capture_output=True, text=True,
                            timeout=400)  # fmt: skip
    assert result.returncode == 1 and "2 failed, 1 passed" in result.stdout, result.stdout[-3000:] + result.stderr
    output = result.stdout.split("= FAILURES =", 1)[1]
    flew, idle = output.split("test_fails_without_the_ground_station", 1)
    for report, status in ((flew, "mode (TAKEOFF|HOLD), armed, MAV_STATE ACTIVE, (takeoff|in air)"),
                           (idle, "mode HOLD, disarmed, MAV_STATE STANDBY, on ground")):  # fmt: skip
        assert "vtol vehicle 1 (call)" in report
        assert re.search(f"status: {status}; failsafe: none announced", report), report
        assert "--- vtol-autopilot (running), last 15 lines of stderr ---" in report
        assert "--- vtol-sim (running), last 15 lines of stderr ---" in report
        paths = [Path(line.strip()) for line in report.splitlines() if line.startswith("  /")]
        assert {path.name for path in paths} >= {"vtol-autopilot.stderr", "vtol-sim.stderr"}
        assert all(path.is_file() for path in paths), paths  # kept after the run
        stderr = next(path for path in paths if path.name == "vtol-sim.stderr").read_text()
        said = report.split("--- vtol-sim (running), last 15 lines of stderr ---\n", 1)[1].splitlines()[0]
        assert said in stderr
    tlog = Path(re.search(r"ground station's MAVLink log: (\S+)", flew).group(1))
    assert tlog.stat().st_size > 1000
    assert "ground station's MAVLink log" not in idle
    ulog = Path(re.search(r"ULog: (\S+)", flew).group(1))  # armed: the flight's log (SDLOG_MODE 0)
    assert ulog.suffix == ".ulg" and ulog.stat().st_size > 1000
    assert "ULog:" not in idle  # never armed
    assert not (base / "test_passes0" / "vtol-0").exists()  # a passing test's folder is removed


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
