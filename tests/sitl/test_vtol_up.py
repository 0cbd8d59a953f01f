"""`vtol up`: plant (real time) + autopilot for a ground station on an instance's ports; Ctrl-C or SIGTERM stops
both cleanly; if one cannot start, the other is stopped too."""

from __future__ import annotations

import os
import random
import re
import signal
import socket
import subprocess
import sys
import time

import pytest

from tests.sitl.ground_station import HOLD, GroundStation
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
