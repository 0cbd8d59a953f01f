"""Parameters (docs/mavlink.md): PX4 bytewise encoding, list/read/set over MAVLink with refusals, a parameter file that
survives a restart and is never broken by a kill -9 in the middle of a write."""

from __future__ import annotations

import json
import math
import random
import signal
import subprocess
import sys
import time

from autopilot.storage.parameters import (
    DEFINITIONS,
    MAV_PARAM_TYPE_INT32,
    MAV_PARAM_TYPE_REAL32,
)
from tests.sitl.mavlink_sitl import start_sitl
from tests.unit.test_mavlink_parameters import BROKEN_FILES, as_int32_bytes
from tiltrotor_sitl._children import run_to_end
from tiltrotor_sitl._commands import AutopilotCommand, Zenoh


def test_the_autopilot_refuses_a_broken_parameter_file_with_one_line_and_exit_2(tmp_path):
    path = tmp_path / "params.json"
    path.write_text(BROKEN_FILES["truncated"])
    result = run_to_end(AutopilotCommand(params=path, zenoh=Zenoh.off()).argv(), timeout_s=60)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vtol-autopilot: error:") and str(path) in lines[0]


WRITER = """
import sys
from pathlib import Path
from autopilot.storage.kept_file import write_atomically
path = Path(sys.argv[1])
documents = [('{"n": %d, "pad": "' % i) + "x" * 200_000 + '"}' for i in range(2)]
print("ready", flush=True)
i = 0
while True:
    write_atomically(path, documents[i % 2])
    i += 1
"""


def test_kill_9_in_the_middle_of_writes_never_leaves_a_broken_file(tmp_path):
    """A process rewriting a 200 kB file as fast as it can is killed at random moments: the file is always whole."""
    path = tmp_path / "params.json"
    rng = random.Random(4)
    interrupted = 0
    for _ in range(8):
        writer = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], stdout=subprocess.PIPE, text=True)
        try:
            assert writer.stdout.readline().strip() == "ready"
            time.sleep(rng.uniform(0.02, 0.15))
        finally:
            writer.send_signal(signal.SIGKILL)
            writer.wait(timeout=20)
        document = json.loads(path.read_text())  # never partial
        assert document["n"] in (0, 1) and len(document["pad"]) == 200_000
        stale = list(tmp_path.glob(".params.json.*.tmp"))
        interrupted += bool(stale)
        for temporary in stale:
            temporary.unlink()
    assert interrupted >= 1  # the kills did land in the middle of writes (the temporary file was left behind)


def test_parameters_over_mavlink_survive_a_restart_and_a_kill_9(tmp_path):
    params_path = tmp_path / "params.json"
    sitl = start_sitl(params_path, spawn_alt=30.0, speed=4.0, controller="pid")
    gs = sitl.gs
    try:
        gs.connect()
        # The whole list: correct count and every index once, INT32 values bytewise.
        gs.conn.mav.param_request_list_send(1, 1)
        gs.wait(lambda: len({p.param_index for p in gs.param_values}) == len(DEFINITIONS), "the parameter list")
        values = {p.param_id: p for p in gs.param_values}
        assert {p.param_count for p in gs.param_values} == {len(DEFINITIONS)}
        assert sorted(p.param_index for p in values.values()) == list(range(len(DEFINITIONS)))
        assert values["SYS_FAILURE_EN"].param_type == MAV_PARAM_TYPE_INT32
        assert values["MAV_SYS_ID"].param_value == as_int32_bytes(1)
        loss = values["COM_OF_LOSS_T"]
        assert loss.param_type == MAV_PARAM_TYPE_REAL32 and loss.param_value == 1.0

        # Set: echoed with the same name, type and value.
        echo = gs.param_set("MIS_TAKEOFF_ALT", 12.5, MAV_PARAM_TYPE_REAL32)
        assert (echo.param_id, echo.param_type, echo.param_value) == ("MIS_TAKEOFF_ALT", MAV_PARAM_TYPE_REAL32, 12.5)
        assert echo.param_index == values["MIS_TAKEOFF_ALT"].param_index
        echo = gs.param_set("SYS_FAILURE_EN", as_int32_bytes(1), MAV_PARAM_TYPE_INT32)
        assert echo.param_value == as_int32_bytes(1)

        # Refusals: the unchanged value comes back, with a STATUSTEXT why.
        echo = gs.param_set("SYS_FAILURE_EN", 0.0, MAV_PARAM_TYPE_REAL32)  # wrong type
        assert echo.param_value == as_int32_bytes(1) and echo.param_type == MAV_PARAM_TYPE_INT32
        echo = gs.param_set("COM_OF_LOSS_T", 1e9, MAV_PARAM_TYPE_REAL32)  # out of range
        assert echo.param_value == 1.0
        echo = gs.param_set("COM_OF_LOSS_T", math.nan, MAV_PARAM_TYPE_REAL32)
        assert echo.param_value == 1.0
        gs.conn.mav.param_set_send(gs.vehicle, 1, b"NO_SUCH_PARAM", 1.0, MAV_PARAM_TYPE_REAL32)
        gs.wait(lambda: any("NO_SUCH_PARAM" in t for t in gs.statustexts), "the unknown-name refusal")
        assert any("SYS_FAILURE_EN: type 9" in t for t in gs.statustexts)
        assert any("COM_OF_LOSS_T" in t and "outside" in t for t in gs.statustexts)

        # Read by name and by index.
        count = len(gs.param_values)
        gs.conn.mav.param_request_read_send(gs.vehicle, 1, b"MIS_TAKEOFF_ALT", -1)
        gs.conn.mav.param_request_read_send(gs.vehicle, 1, b"", values["SYS_FAILURE_EN"].param_index)
        gs.wait(lambda: len(gs.param_values) >= count + 2, "two PARAM_VALUEs")
        read = {p.param_id: p.param_value for p in gs.param_values[count:]}
        assert read == {"MIS_TAKEOFF_ALT": 12.5, "SYS_FAILURE_EN": as_int32_bytes(1)}

        # A burst of changes, then kill -9 while the file is being rewritten: the file is whole.
        for i in range(300):
            gs.conn.mav.param_set_send(gs.vehicle, 1, b"MPC_XY_CRUISE", 2.0 + (i % 7), MAV_PARAM_TYPE_REAL32)
        gs.pump(0.05)
        sitl.autopilot.send_signal(signal.SIGKILL)
        sitl.autopilot.wait(timeout=20)
        saved = json.loads(params_path.read_text())["parameters"]
        assert saved["MIS_TAKEOFF_ALT"] == 12.5 and saved["SYS_FAILURE_EN"] == 1

        # A new autopilot on the same file and ports has the values.
        sitl.restart_autopilot()  # the same command line: --controller pid --spawn-alt 30
        gs.param_values.clear()
        gs.latest.pop("HEARTBEAT", None)
        gs.wait(lambda: "HEARTBEAT" in gs.latest, "the restarted autopilot", timeout_s=60)
        gs.conn.mav.param_request_read_send(gs.vehicle, 1, b"MIS_TAKEOFF_ALT", -1)
        gs.conn.mav.param_request_read_send(gs.vehicle, 1, b"SYS_FAILURE_EN", -1)
        gs.wait(lambda: {p.param_id for p in gs.param_values} >= {"MIS_TAKEOFF_ALT", "SYS_FAILURE_EN"}, "values",
                every=lambda: gs.conn.mav.param_request_read_send(gs.vehicle, 1, b"MIS_TAKEOFF_ALT", -1))  # fmt: skip
        read = {p.param_id: p.param_value for p in gs.param_values}
        assert read["MIS_TAKEOFF_ALT"] == 12.5 and read["SYS_FAILURE_EN"] == as_int32_bytes(1)
    finally:
        sitl.kill()
