"""The MPC solving one tick ahead on its solver's worker thread (autopilot/mpc/overlap.py, VT_MPC_OVERLAP): the
maths of the prediction, the C back-end's steps on the worker thread equal to the same steps taken here, a failure
reaching the next solve, and lockstep flights through the real processes that repeat bit for bit."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tiltrotor_sitl import ProcessOptions, Vehicle
from transport.flight_log import VN, VN_SP, read_flight_log


def fly_accel(tmp_path: Path, name: str, overlap: int, duration_s: float = 3.0) -> tuple[bytes, dict]:
    """The MPC flying 3 s of the acceleration profile in lockstep; the 100 Hz log's bytes and the summary."""
    log = tmp_path / f"{name}.csv"
    with Vehicle(
        controller="mpc",
        spawn_alt=100.0,
        speed=None,
        truth=False,
        params={"VT_MPC_OVERLAP": overlap},
        processes=ProcessOptions(
            summary=True,
            duration_s=duration_s,
            wait_ready=False,
            autopilot_args=("--profile", "accel", "--log", str(log), "--quiet"),
        ),
    ) as vehicle:
        vehicle.wait_finished(timeout_s=300.0)
        summary = vehicle.summary("vtol-autopilot")
    return log.read_bytes(), summary


def test_overlapped_lockstep_flights_repeat_bit_for_bit_and_differ_from_the_synchronous_one(tmp_path):
    first, summary = fly_accel(tmp_path, "a", 1)
    second, _ = fly_accel(tmp_path, "b", 1)
    synchronous, synchronous_summary = fly_accel(tmp_path, "sync", 0)
    assert first == second
    assert first != synchronous  # the one-tick delay is real
    for flight in (summary, synchronous_summary):
        assert flight["controller"]["solves_failed"] == 0 and not flight["controller"]["fell_back_to_pid"]
    # Both track the ramp alike: the delay is compensated (0.23 m/s RMS in-process over 6 s for either).
    errors = []
    for name in ("a", "sync"):
        log = read_flight_log(tmp_path / f"{name}.csv").columns
        errors.append(float(np.sqrt(np.mean((log[VN] - log[VN_SP]) ** 2))))
    assert errors[0] < 0.5 and abs(errors[0] - errors[1]) < 0.05 * errors[1]
