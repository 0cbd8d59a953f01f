import dataclasses

import numpy as np

from autopilot.topics.vehicle_state import VehicleState


def test_with_velocity_is_replace_with_another_velocity() -> None:
    state = VehicleState(time_usec=12_500, airspeed=7.5, valid=True)
    state.position_ned[:] = (1.0, 2.0, -3.0)
    state.euler[:] = (0.1, -0.2, 0.3)
    velocity = np.array([4.0, 5.0, 6.0])
    fast, reference = state.with_velocity(velocity), dataclasses.replace(state, velocity_ned=velocity)
    for f in dataclasses.fields(VehicleState):  # every field, so one added to the class but not to the method fails
        assert getattr(fast, f.name) is getattr(reference, f.name), f.name
