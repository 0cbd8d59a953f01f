"""`vtol record` and `vtol watch`: the pure data handling without zenoh, the recorder against an in-process
publisher on loopback, and both commands against a real plant and autopilot (killed by PID at the end)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time

import pytest

from ground_tools.telemetry_record import (
    TelemetryRecorder,
    read_recording,
)
from tests.unit.test_zenoh_tools import control_payload, plant_payload
from tiltrotor_sitl import ProcessOptions, Vehicle
from tiltrotor_sitl._free_ports import free_zenoh_endpoint
from transport.telemetry import (
    PLANT_STATE_FIELDS,
    control_key,
    plant_state_key,  # fmt: skip
)

VTOL = [sys.executable, "-m", "ground_tools"]
STATUS = re.compile(r"t=\s*([-\d.]+) s\s+alt=\s*([-\d.]+) m")


def test_an_endpoint_zenoh_refuses_gives_one_line_and_exit_code_2(tmp_path):
    result = subprocess.run([*VTOL, "record", "--out", str(tmp_path / "r.jsonl"), "--connect", "bogus/127.0.0.1:1"],
                            capture_output=True, text=True, timeout=60)  # fmt: skip
    assert result.returncode == 2
    assert result.stderr == "vtol: error: cannot open a zenoh session to bogus/127.0.0.1:1: " \
                            "Unicast not supported for bogus protocol\n"  # fmt: skip


# ---- the recorder on loopback, in process --------------------------------------------------------------------------
def test_recorder_writes_every_sample_received_before_stop(tmp_path):
    import zenoh

    from transport.zenoh_bus import session_config

    endpoint = free_zenoh_endpoint()
    path = tmp_path / "rec.jsonl"
    with zenoh.open(session_config(listen=[endpoint], connect=[])) as publisher:
        recorder = TelemetryRecorder([endpoint], path, sysid=1)
        with recorder:
            deadline = time.monotonic() + 20
            while not recorder.counts and time.monotonic() < deadline:  # until the recorder's session is through
                publisher.put("vtol/1/probe", b"{}")
                time.sleep(0.05)
            for k in range(500):
                publisher.put(plant_state_key(1), plant_payload(t=k / 400))
            publisher.put(control_key(1), control_payload())
            publisher.put(plant_state_key(1), b"short")
            publisher.put(plant_state_key(2), plant_payload())  # another vehicle: not recorded
            deadline = time.monotonic() + 20
            while recorder.counts[plant_state_key(1)] < 501 and time.monotonic() < deadline:
                time.sleep(0.02)
        counts = recorder.stop()  # a second stop is harmless
    assert counts[plant_state_key(1)] == 501 and counts[control_key(1)] == 1 and plant_state_key(2) not in counts
    assert recorder.errors == {plant_state_key(1): 1}
    records = list(read_recording(path))
    assert len(records) == sum(counts.values())  # all of it on disk
    states = [r["payload"] for r in records if r["key"] == plant_state_key(1) and "payload" in r]
    assert [s["t"] for s in states] == [k / 400 for k in range(500)]  # in order, none lost
    errors = [r for r in records if "error" in r]
    assert errors == [{"key": plant_state_key(1), "bytes": 5,
                       "error": "plant state payload has 5 bytes, expected a multiple of 344"}]  # fmt: skip


# ---- against a real plant and autopilot ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def vehicle():
    """A vehicle (tiltrotor_sitl.Vehicle: real time, hovering at 100 m, PID) with zenoh on free loopback ports;
    yields its plant's and autopilot's endpoints. Real time x1: on a loaded 2-core machine an autopilot that cannot
    keep up with a faster real-time plant (x5 PID, x2 MPC were seen) lets the vehicle fall, and the tests check
    ~100 m."""
    with Vehicle(
        controller="pid", spawn_alt=100.0, speed=1.0, processes=ProcessOptions(autopilot_args=("--quiet",))
    ) as started:
        yield [started.ports.zenoh_plant, started.ports.zenoh_autopilot]


def connect_args(endpoints: list[str]) -> list[str]:
    return [arg for endpoint in endpoints for arg in ("--connect", endpoint)]


def test_vtol_record_writes_decodable_plant_and_autopilot_records(tmp_path, vehicle):
    out = tmp_path / "rec.jsonl"
    result = subprocess.run([*VTOL, "record", "--out", str(out), *connect_args(vehicle), "--duration", "2"],
                            capture_output=True, text=True, timeout=60)  # fmt: skip
    assert result.returncode == 0, result.stderr
    printed = dict(line.rsplit(": ", 1) for line in result.stdout.splitlines())
    records = list(read_recording(out))
    states = [r["payload"] for r in records if r["key"] == "vtol/1/plant/state"]
    controls = [r["payload"] for r in records if r["key"] == "vtol/1/autopilot/control"]
    assert int(printed["vtol/1/plant/state"]) == len(states) > 200  # 400 states per wall second
    assert int(printed["vtol/1/autopilot/control"]) == len(controls) > 50
    assert not [r for r in records if "error" in r]
    assert all(set(s) == set(PLANT_STATE_FIELDS) for s in states)
    assert all(abs(-s["down"] - 100.0) < 5.0 for s in states)
    assert all(len(c["u"]) == 8 and len(c["velocity_sp"]) == 3 and isinstance(c["mode"], str) for c in controls)
    times = [s["t"] for s in states]
    assert times == sorted(times) and 1.0 < times[-1] - times[0] < 3.0  # about 2 wall s


def test_vtol_record_stops_on_sigterm_with_a_complete_file(tmp_path, vehicle):
    out = tmp_path / "rec.jsonl"
    record = subprocess.Popen([*VTOL, "record", "--out", str(out), "--connect", vehicle[0]],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
    try:
        deadline = time.monotonic() + 30
        while (not out.exists() or out.stat().st_size < 10_000) and time.monotonic() < deadline:
            time.sleep(0.1)  # the file grows while recording (flushed every 0.5 s)
        record.send_signal(signal.SIGTERM)
        stdout, stderr = record.communicate(timeout=30)
    finally:
        if record.poll() is None:
            record.kill()
            record.wait()
    assert record.returncode == 0, stderr
    counts = {key: int(n) for key, n in re.findall(r"^(vtol/\S+): (\d+)$", stdout, re.MULTILINE)}
    assert counts["vtol/1/plant/state"] > 0 and out.read_text().endswith("\n")
    assert sum(counts.values()) == len(list(read_recording(out)))  # everything received is on disk
    assert "Traceback" not in stderr


def test_vtol_watch_prints_status_lines_and_writes_a_snapshot(tmp_path, vehicle):
    snapshot = tmp_path / "watch.png"
    env = {key: value for key, value in os.environ.items() if key not in ("DISPLAY", "WAYLAND_DISPLAY")}
    command = [*VTOL, "watch", "--text", "--duration", "3", *connect_args(vehicle), "--snapshot", str(snapshot)]
    result = subprocess.run(command, capture_output=True, text=True, timeout=60, env=env)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert 2 <= len(lines) <= 6, lines  # one a second (3), give or take a stall and its catch-up on a loaded machine
    status = [m for m in map(STATUS.search, lines) if m]
    assert len(status) >= 2 and status[-1].string == lines[-1], lines  # (a loaded machine may connect late)
    assert all(abs(float(m.group(2)) - 100.0) < 5.0 for m in status), lines
    assert float(status[-1].group(1)) > float(status[0].group(1))  # simulation time moves on
    assert "mode=" in lines[-1] and "mpc=-" in lines[-1]  # the PID flies: no MPC solutions
    assert snapshot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert re.search(r"vtol: \d+ samples received", result.stderr) and "Traceback" not in result.stderr


def test_vtol_watch_without_a_vehicle_says_so_and_exits_1(tmp_path):
    command = [*VTOL, "watch", "--text", "--duration", "1.2", "--connect", free_zenoh_endpoint()]
    result = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert result.returncode == 1, result.stderr
    assert result.stdout.splitlines() == ["t=- (no plant state yet)  mode=-  mpc=-  (no new samples)"]
    assert "vtol: 0 samples received" in result.stderr


def test_vtol_record_without_a_vehicle_says_so_and_exits_1(tmp_path):
    command = [*VTOL, "record", "--out", str(tmp_path / "r.jsonl"), "--duration", "1.2", "--no-progress",
               "--connect", free_zenoh_endpoint()]  # fmt: skip
    result = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert result.returncode == 1, result.stderr
    assert "vtol: error: nothing received: is a vehicle publishing on" in result.stderr
    assert (tmp_path / "r.jsonl").read_text() == ""
