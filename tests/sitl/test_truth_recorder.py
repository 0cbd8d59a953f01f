"""The truth's history on a real flight (tiltrotor_sitl/truth.py): asked after the vehicle has landed, its highest
sample is the plant's, as the autopilot logged the plant's states over MAVLink; a condition that held for a single
physics step before the wait began is found when asked to look back, and only then."""

from __future__ import annotations

import pytest

from tiltrotor_sitl import ProcessOptions, TruthTimeout, Vehicle
from transport.flight_log import DOWN, read_flight_log


def test_the_highest_point_of_a_landed_flight_and_a_single_step_before_the_wait(tmp_path) -> None:
    log = tmp_path / "flight.csv"
    with Vehicle(speed=None, folder=tmp_path, processes=ProcessOptions(autopilot_args=("--log", str(log)))) as vehicle:
        gcs = vehicle.ground_station
        gcs.arm()
        gcs.takeoff(8.0)
        vehicle.truth.wait_until(lambda s: s.altitude > 7.8, timeout_sim_s=60, what="the climb")
        gcs.land()
        vehicle.truth.wait_until(lambda s: s.on_ground, timeout_sim_s=90, what="the landing")

        highest = vehicle.truth.max(lambda s: s.altitude)
        climbed_past_4m = vehicle.truth.first(lambda s: s.altitude > 4.0)
        one_step = lambda s: s.t == climbed_past_4m.t  # noqa: E731 (holds for that 2.5 ms step alone)
        found = vehicle.truth.wait_until(one_step, timeout_sim_s=1.0, include_past=True)
        with pytest.raises(TruthTimeout, match="did not hold within 1 simulated seconds"):
            vehicle.truth.wait_until(one_step, timeout_sim_s=1.0)
    logged = -read_flight_log(log)[DOWN]  # the plant's states, as the autopilot received them (HIL_STATE_QUATERNION)
    assert abs(highest.altitude - logged.max()) < 0.05, (highest.altitude, logged.max())
    assert 7.8 < highest.altitude < 8.6
    assert found == climbed_past_4m and found.altitude > 4.0
