"""zenoh telemetry while flying: a loopback subscriber receives plant truth, control samples and MPC solutions."""

from __future__ import annotations

import time
from collections import Counter

import numpy as np
import zenoh

from ground_tools.telemetry_record import decode_samples
from tiltrotor_sitl import Controller, ProcessOptions, Vehicle
from transport.telemetry import control_key, mpc_key, plant_state_key
from transport.zenoh_bus import session_config

payloads: Counter[str] = Counter()
END_SLACK_S = 0.1  # the last sample of each key is within a control tick (10 ms) of the flight's end; margin


def fly_with_subscriber(controller: Controller, duration: str, *keys: str) -> dict[str, list]:
    """Plant + autopilot (lockstep, accel profile) with zenoh on loopback; the samples a subscriber got per key
    (and their payloads counted in `payloads`). It connects as the processes start (they take a second or more to
    begin stepping)."""
    received: dict[str, list] = {key: [] for key in keys}
    latest_t = dict.fromkeys(keys, -1.0)  # the latest simulation time received per key
    payloads.clear()

    def on_sample(key: str, sample: zenoh.Sample) -> None:
        samples = decode_samples(key, bytes(sample.payload))
        received[key].extend(samples)
        latest_t[key] = max([latest_t[key]] + [s["t"] for s in samples])
        payloads[key] += 1

    with Vehicle(
        controller=controller,
        spawn_alt=100.0,
        speed=None,
        processes=ProcessOptions(duration_s=float(duration), wait_ready=False, autopilot_args=("--profile", "accel")),
    ) as vehicle:
        endpoints = [vehicle.ports.zenoh_plant, vehicle.ports.zenoh_autopilot]
        session = zenoh.open(session_config(listen=[], connect=endpoints))
        try:
            for key in keys:
                session.declare_subscriber(key, lambda sample, k=key: on_sample(k, sample))
            vehicle.wait_finished(timeout_s=300)  # (an autopilot that exits with an error fails the test here)
            # The last samples, put as the processes ended, may still be on their way: wait until every key's reach
            # the flight's end in simulation time (the wall clock only as a guard).
            end_s = float(duration) - END_SLACK_S
            deadline = time.monotonic() + 20
            while min(latest_t.values()) < end_s:
                assert time.monotonic() < deadline, f"samples up to {latest_t} s, not to the end ({duration} s)"
                time.sleep(0.01)
            print(f"the last samples at {latest_t} s of a {duration} s flight")
        finally:
            session.close()
    return received


def test_subscriber_receives_plant_truth_and_autopilot_control(tmp_path):
    received = fly_with_subscriber("pid", "20", plant_state_key(1), control_key(1))
    states, controls = received[plant_state_key(1)], received[control_key(1)]
    assert len(states) > 1000 and len(controls) > 100
    assert max(s["vn"] for s in states) > 25.0  # the truth shows the flight
    modes = {c["mode"] for c in controls}
    # The subscriber reaches the autopilot some seconds in (zenoh retries its connection to a port not yet open):
    # how many depends on the machine's load, so only the end of the flight is sure to be seen.
    assert "FW" in modes
    assert all(len(c["u"]) == 8 and len(c["tilt_cmd"]) == 4 for c in controls)
    # In lockstep the autopilot gathers its samples, up to 10 a payload, and none is lost: from the first one
    # received to the end of the flight (the last gathered ones put as it ends) every 10 ms tick is there.
    assert payloads[control_key(1)] < len(controls) / 5
    times = np.array([c["t"] for c in controls])
    assert np.allclose(np.diff(times), 0.01, atol=1e-6) and times[-1] > 19.9


def test_subscriber_receives_the_mpc_solutions(tmp_path):
    received = fly_with_subscriber("mpc", "10", plant_state_key(1), mpc_key(1))
    solutions = received[mpc_key(1)]
    assert len(received[plant_state_key(1)]) > 1000 and len(solutions) > 100
    assert all(s["ok"] and len(s["predicted_velocity"]) == 26 and len(s["predicted_tilt"][0]) == 4 for s in solutions)
    assert all(0 < s["solve_time_ms"] < 100 and s["qp_iterations"] > 0 for s in solutions)
