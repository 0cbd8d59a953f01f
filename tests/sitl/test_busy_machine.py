"""An interactive session on a busy machine (docs/faults.md): with a lockstep scenario flying beside it on the same
cores, a vehicle in paced lockstep with the MPC flies a pymavlink script's Offboard velocity profile without falling
back to the PID and without a failsafe; the simulation slows down instead, and says how far."""

from __future__ import annotations

import sys
from pathlib import Path

from ground_tools.busy_flight import fly_profile

VTOL = [sys.executable, "-m", "ground_tools"]


def test_the_mpc_flies_an_offboard_profile_with_a_lockstep_scenario_beside_it(tmp_path: Path) -> None:
    beside = [*VTOL, "scenario", "all", "--controller", "mpc", "--jobs", "1", "--no-record",  # killed at the end
              "--no-progress", "--out", str(tmp_path / "beside")]  # fmt: skip
    flight = fly_profile(tmp_path / "busy", duration_s=12.0, beside=beside)
    print(flight)
    assert flight.beside_ran_throughout, (tmp_path / "busy" / "beside.log").read_text()
    assert not flight.fell_back_to_pid and not flight.offboard_left
    assert flight.samples > 0.9 * (12.0 - 2.0) * 30  # LOCAL_POSITION_NED at 30 Hz of simulated time
    assert max(flight.rms_ned) < 0.6  # a fall-back or a fall: metres per second
    assert 0.0 < flight.real_time_factor <= 1.05
