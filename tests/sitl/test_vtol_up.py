"""`vtol up`: plant (real time) + autopilot for a ground station on an instance's ports; Ctrl-C or SIGTERM stops
both cleanly; if one cannot start, the other is stopped too. --reset-params and --gcs-bind (and the API's
gcs_bind) as a ground station sees them."""

from __future__ import annotations

import json
import os
import random
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from autopilot.storage.parameters import BY_NAME
from tests.sitl.ground_station import HOLD, GroundStation
from tiltrotor_sitl import Vehicle
from transport.ports import MAX_SYSID, Ports

VTOL = os.path.join(os.path.dirname(sys.executable), "vtol")


def free_instance(ground_station: bool = True) -> int:
    """An instance whose UDP ports are all free here; below MAX_SYSID, so its system id (instance + 1) tells its
    vehicle apart from others on 14550. ground_station False: only the ports the vehicle binds (not 14550, where
    every instance's GCS link sends and another test's ground station may listen)."""
    rng = random.Random()
    for _ in range(50):
        instance = rng.randint(100, MAX_SYSID - 1)
        ports = Ports(instance)
        sockets = []
        try:
            listened = (ports.gcs_remote, ports.api_remote) if ground_station else ()
            for port in (ports.plant, ports.gcs_bind, ports.api_bind, *listened):
                s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                sockets.append(s)
                s.bind(("127.0.0.1", port))
            return instance
        except OSError:
            continue
        finally:
            for s in sockets:
                s.close()
    raise AssertionError("no free instance")


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie (exited, not yet reaped by a parent that is gone) counts as stopped
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().split(") ")[1][0] != "Z"
    except OSError:
        return False


@pytest.mark.parametrize("how", ["ctrl-c", "sigterm"])
def test_vtol_up_serves_a_ground_station_and_stops_both_processes(tmp_path, how):
    instance = free_instance()
    ports = Ports(instance)
    gs = GroundStation(ports.gcs_remote, ports.system_id)
    errors = tmp_path / "vtol.stderr"
    signing = []
    if how == "sigterm":  # and the plant link signed: the pair flies only if vtol up gave both the key
        (tmp_path / "plant.key").write_text("5a" * 32)
        signing = ["--plant-signing-key", str(tmp_path / "plant.key")]
    with open(errors, "w") as stderr:
        vtol = subprocess.Popen([VTOL, "up", "--instance", str(instance), "--spawn-alt", "20", "--speed", "2",
                                 "--controller", "pid", "--no-zenoh", "--params", str(tmp_path / "params.json"),
                                 *signing], stdout=subprocess.DEVNULL, stderr=stderr, start_new_session=True)  # fmt: skip
    try:
        gs.connect(timeout_s=60)
        assert gs.armed and gs.mode == HOLD
        gs.wait_sim(1.0)
        assert abs(gs.altitude - 20.0) < 1.0
        text = errors.read_text()
        pids = [int(p) for p in re.findall(r"plant pid (\d+).*autopilot pid (\d+)", text)[0]]
        assert f"udp 127.0.0.1:{ports.gcs_remote}" in text and f"udpin://127.0.0.1:{ports.api_remote}" in text
        if how == "ctrl-c":
            os.killpg(vtol.pid, signal.SIGINT)  # what the terminal does: the whole foreground group
        else:
            vtol.send_signal(signal.SIGTERM)
        assert vtol.wait(timeout=20) == 0
        assert not any(alive(pid) for pid in pids)
        text = errors.read_text()
        assert "vtol: stopped" in text and "Traceback" not in text
    finally:
        if vtol.poll() is None:
            os.killpg(vtol.pid, signal.SIGKILL)
            vtol.wait()
        gs.close()


def test_vtol_up_stops_the_plant_when_the_autopilot_cannot_start(tmp_path):
    instance = free_instance()
    blocker = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    blocker.bind(("127.0.0.1", Ports(instance).gcs_bind))  # the autopilot's GCS port is taken
    try:
        command = [VTOL, "up", "--instance", str(instance), "--no-zenoh", "--params", str(tmp_path / "params.json")]
        result = subprocess.run(command, capture_output=True, text=True, timeout=60)
    finally:
        blocker.close()
    assert result.returncode == 1  # a process ended by itself (its own code, 2, in the line below)
    assert f"cannot bind UDP 127.0.0.1:{Ports(instance).gcs_bind} (GCS link)" in result.stderr
    assert "vtol-autopilot ended (exit code 2)" in result.stderr
    pid = int(re.search(r"plant pid (\d+)", result.stderr).group(1))
    time.sleep(0.2)
    assert not alive(pid)


def test_a_killed_vtol_up_leaves_no_vehicle_flying(tmp_path):
    """SIGKILL to `vtol up` alone (no chance to stop anything): its plant and autopilot learn it from their
    parent-death signal and stop, so no vehicle holds its ports with no one to stop it."""
    instance = free_instance(ground_station=False)
    errors = tmp_path / "vtol.stderr"
    with open(errors, "w") as stderr:
        vtol = subprocess.Popen([VTOL, "up", "--instance", str(instance), "--controller", "pid", "--no-zenoh",
                                 "--params", str(tmp_path / "params.json")], stdout=subprocess.DEVNULL, stderr=stderr,
                                start_new_session=True)  # fmt: skip
    try:
        deadline = time.monotonic() + 60
        while not (found := re.findall(r"plant pid (\d+).*autopilot pid (\d+)", errors.read_text())):
            assert time.monotonic() < deadline and vtol.poll() is None, errors.read_text()
            time.sleep(0.1)
        pids = [int(p) for p in found[0]]
        time.sleep(3.0)  # both started and running
        assert all(alive(pid) for pid in pids)
        vtol.kill()
        vtol.wait(timeout=10)
        deadline = time.monotonic() + 20
        while any(alive(pid) for pid in pids) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not any(alive(pid) for pid in pids)
    finally:
        if vtol.poll() is None:
            vtol.kill()
        subprocess.run(["pkill", "-KILL", "-s", str(vtol.pid)], check=False)  # its session, should any be left


@contextmanager
def vtol_up(tmp_path, instance: int, *options: str) -> Iterator[GroundStation]:
    """`vtol up` (PID, real time x2, no zenoh) on `instance` with `options`, its ground station connected; both
    stopped at the end."""
    ports = Ports(instance)
    gs = GroundStation(ports.gcs_remote, ports.system_id)
    with open(tmp_path / "vtol.stderr", "a") as stderr:
        vtol = subprocess.Popen([VTOL, "up", "--instance", str(instance), "--speed", "2", "--controller", "pid",
                                 "--no-zenoh", *options], stdout=subprocess.DEVNULL, stderr=stderr,
                                start_new_session=True)  # fmt: skip
    try:
        gs.connect(timeout_s=60)
        yield gs
    finally:
        if vtol.poll() is None:
            vtol.send_signal(signal.SIGTERM)
            try:
                vtol.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(vtol.pid, signal.SIGKILL)
                vtol.wait()
        gs.close()


def read_parameter(gs: GroundStation, name: str) -> float:
    """PARAM_REQUEST_READ by name, as a ground station reads one parameter; its PARAM_VALUE's value."""
    start = len(gs.param_values)
    gs.conn.mav.param_request_read_send(gs.vehicle, 1, name.encode(), -1)
    found: list = []

    def answered() -> bool:
        found.extend(p for p in gs.param_values[start:] if p.param_id == name)
        return bool(found)

    gs.wait(answered, f"PARAM_VALUE {name}", 10.0)
    return found[0].param_value


def test_vtol_up_reset_params_brings_a_changed_parameter_in_the_file_back_to_its_default(tmp_path):
    instance = free_instance()
    params = tmp_path / "params.json"
    params.write_text(json.dumps({"format": "tiltrotor-sitl parameters", "version": 1,
                                  "parameters": {"MPC_TKO_SPEED": 2.5}}))  # fmt: skip
    default = BY_NAME["MPC_TKO_SPEED"].default
    assert default != 2.5
    with vtol_up(tmp_path, instance, "--params", str(params)) as gs:  # without the option the file's value stands
        assert read_parameter(gs, "MPC_TKO_SPEED") == pytest.approx(2.5)
    with vtol_up(tmp_path, instance, "--params", str(params), "--reset-params") as gs:
        assert read_parameter(gs, "MPC_TKO_SPEED") == pytest.approx(default)
    assert "MPC_TKO_SPEED" not in json.loads(params.read_text())["parameters"]


def test_vtol_up_gcs_bind_listens_on_the_address_given(tmp_path):
    instance = free_instance()
    ports = Ports(instance)
    with vtol_up(tmp_path, instance, "--params", str(tmp_path / "params.json"), "--gcs-bind", "127.0.0.1") as gs:
        assert gs.conn.clients == {("127.0.0.1", ports.gcs_bind)}  # the vehicle speaks from there
        assert read_parameter(gs, "MAV_SYS_ID") > 0  # and hears the ground station's answer there


def test_a_vehicle_with_gcs_bind_127_0_0_2_is_reached_there_and_not_on_127_0_0_1():
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        probe.bind(("127.0.0.2", 0))
    except OSError as exc:
        pytest.skip(f"this machine does not let one bind 127.0.0.2: {exc}")
    finally:
        probe.close()
    with Vehicle(controller="pid", speed=0, truth=False, gcs_bind="127.0.0.2") as vehicle:
        gcs = vehicle.ground_station
        gcs_bind = vehicle.ports.links.gcs_bind
        assert gcs.connection.clients == {("127.0.0.2", gcs_bind)}
        assert gcs.get_parameter("MAV_SYS_ID") == vehicle.sysid  # a round trip through 127.0.0.2
        elsewhere = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            elsewhere.bind(("127.0.0.1", gcs_bind))  # free: the vehicle listens on 127.0.0.2 alone
        finally:
            elsewhere.close()
    with Vehicle(controller="pid", speed=0, truth=False, gcs_bind="127.0.0.2") as vehicle:
        asked = vehicle.status()  # no ground station in use: asked on 127.0.0.2, where the link listens
        assert (asked.mode, asked.armed) == ("HOLD", False), asked
