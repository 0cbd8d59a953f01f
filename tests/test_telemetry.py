"""zenoh telemetry while flying: a loopback subscriber receives plant truth and the autopilot's control samples."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import zenoh

from ground_tools.lockstep_flight import free_udp_port
from tests.conftest import free_tcp_port
from transport.telemetry import control_key, decode_plant_state, plant_state_key
from transport.zenoh_bus import session_config


def test_subscriber_receives_plant_truth_and_autopilot_control(tmp_path):
    plant_endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    autopilot_endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    port = str(free_udp_port())
    states, controls = [], []
    session = zenoh.open(session_config(listen=[], connect=[plant_endpoint, autopilot_endpoint]))
    session.declare_subscriber(plant_state_key(1), lambda s: states.append(decode_plant_state(bytes(s.payload))))
    session.declare_subscriber(control_key(1), lambda s: controls.append(json.loads(bytes(s.payload))))
    plant = subprocess.Popen(
        [sys.executable, "-m", "sim_bridge", "--port", port, "--spawn-alt", "100", "--duration", "20",
         "--zenoh-listen", plant_endpoint], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        time.sleep(1.0)  # let the subscriber's session reach the plant's endpoint before it steps
        autopilot = subprocess.run(
            [sys.executable, "-m", "autopilot", "--sim-port", port, "--spawn-alt", "100", "--profile", "accel",
             "--duration", "20", "--zenoh-listen", autopilot_endpoint], capture_output=True, text=True, timeout=300,
        )  # fmt: skip
        assert autopilot.returncode == 0, autopilot.stderr
        plant.wait(timeout=60)
        time.sleep(0.5)
    finally:
        if plant.poll() is None:
            plant.kill()
            plant.wait()
        session.close()
    assert len(states) > 1000 and len(controls) > 100
    assert max(s["vn"] for s in states) > 25.0  # the truth shows the flight
    modes = {c["mode"] for c in controls}
    assert {"TRANSITION_FW", "FW"} <= modes  # (the subscriber reaches the autopilot a few seconds in)
    assert all(len(c["u"]) == 8 and len(c["tilt_cmd"]) == 4 for c in controls)
