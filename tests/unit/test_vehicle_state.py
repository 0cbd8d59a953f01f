import dataclasses
import math

import numpy as np

from autopilot.topics.vehicle_state import VehicleState, update_from_hil_state
from transport.geodesy import Home, LocalGeodetic
from transport.mavlink import mavlink


def test_with_velocity_is_replace_with_another_velocity() -> None:
    state = VehicleState(time_usec=12_500, airspeed=7.5, valid=True)
    state.position_ned[:] = (1.0, 2.0, -3.0)
    state.euler[:] = (0.1, -0.2, 0.3)
    velocity = np.array([4.0, 5.0, 6.0])
    fast, reference = state.with_velocity(velocity), dataclasses.replace(state, velocity_ned=velocity)
    for f in dataclasses.fields(VehicleState):  # every field, so one added to the class but not to the method fails
        assert getattr(fast, f.name) is getattr(reference, f.name), f.name


def test_update_from_hil_state_normalises_and_converts_to_the_last_bit() -> None:
    """Against the definition: finite check, quaternion normalised by its norm summed in order, units converted."""
    home = Home(47.397742, 8.545594, 488.0)
    rng = np.random.default_rng(7)
    for _ in range(200):
        q = rng.normal(0.0, 0.5, 4).tolist()
        rates = rng.normal(0.0, 1.0, 3).tolist()
        message = mavlink.MAVLink_hil_state_quaternion_message(
            123_456, q, *rates, 473977420, 85455940, 488000, 120, -340, 56, 1500, 1510, 10, -20, -1000
        )
        state = VehicleState()
        accepted = update_from_hil_state(state, message, LocalGeodetic(home), 9.81)
        norm = math.sqrt(sum(v * v for v in q))
        assert accepted == (0.5 < norm < 1.5)
        if accepted:
            assert state.quaternion.tolist() == [v / norm for v in q]
            assert state.body_rates.tolist() == rates
            assert state.velocity_ned.tolist() == [1.2, -3.4, 0.56]
            assert state.specific_force.tolist() == [10 * 9.81 / 1000, -20 * 9.81 / 1000, -1000 * 9.81 / 1000]


def test_update_from_hil_state_refuses_what_is_not_finite() -> None:
    for bad in range(7):
        values = [1.0, 0.0, 0.0, 0.0, 0.1, 0.2, 0.3]
        values[bad] = math.nan
        message = mavlink.MAVLink_hil_state_quaternion_message(
            1, values[0:4], *values[4:7], 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0
        )
        state = VehicleState()
        assert not update_from_hil_state(state, message, LocalGeodetic(Home(47.0, 8.0, 500.0)), 9.81)
        assert not state.valid
