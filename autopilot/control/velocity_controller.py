"""What every velocity controller (the unified MPC, the PID baseline) offers the flight controller, and what the one
flown first with the PID as its back-up (the MPC) offers besides.

A velocity controller runs at 100 Hz: the vehicle state (its velocity already the estimate), the NED velocity
set-point, the servo estimate's tilts and the yaw reference (None: the controller's own rule: the set-point's course,
or the yaw held at low speed) in, a VelocityCommand out (attitude set-point for the attitude loop,
tilts for the servos, the body force for the allocator, the phase name). tests/test_velocity_controller_contract.py
checks every controller against this protocol through the real classes.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from autopilot.control.actuator_health import ServoEstimate
from autopilot.control.allocation import ControlAllocator
from autopilot.control.velocity_command import VelocityCommand
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawReference


class VelocityController(Protocol):
    """Velocity set-point (NED, m/s) -> VelocityCommand, once per 100 Hz tick, in time order.

    update's contract (for finite inputs): every number of the command finite; the attitude set-point's roll
    and pitch and the tilt set-points within the controller's limits; `mode` a non-empty phase name; the same
    sequence of calls gives the same commands.
    """

    mode_switches: int  # phase changes so far (0 for a controller without phases)

    def update(self, state: VehicleState, v_sp: np.ndarray, tilts: np.ndarray,
               yaw: YawReference | None = None) -> VelocityCommand:  # fmt: skip
        """One tick; `tilts` is the autopilot's estimate of the rotors' present tilts (rad); `yaw` the yaw to follow
        (given only while the set-point is a multicopter's), None: the controller's own rule."""
        ...


class PrimaryVelocityController(VelocityController, Protocol):
    """A velocity controller flown with the PID baseline as its back-up (the unified MPC, synchronous or
    overlapped): it asks for the back-up after repeated failed solves and reports its solver."""

    @property
    def fallback_requested(self) -> bool:
        """The back-up should fly from now on."""
        ...

    @property
    def failures_in_row(self) -> int: ...

    @property
    def last_solution(self) -> object | None:
        """The latest solve (a new object each solve), None before the first."""
        ...

    def solution_summary(self) -> dict:
        """The latest solve's telemetry payload (docs/telemetry.md, `vtol/<sysid>/autopilot/mpc`)."""
        ...

    def retune(self, params: ParameterStore) -> None:
        """The parameters' gains, weights and limits from the next solve on."""
        ...

    def health_changed(self, allocator: ControlAllocator, servos: ServoEstimate) -> None:
        """A failure became known to the allocator and the servo estimate it shares."""
        ...

    def statistics(self) -> dict:
        """The solver's figures for the flight's summary."""
        ...
