"""The flight controller's internals on zenoh (docs/telemetry.md): set-points, actuators, wrench and residual at
100 Hz (vtol/<sysid>/autopilot/control), and each MPC solve (vtol/<sysid>/autopilot/mpc)."""

from __future__ import annotations

from typing import Any

from aircraft.actuators import TILTS, allocated_of
from autopilot.flight_controller import FlightController
from autopilot.mpc_controller import solution_summary
from transport.telemetry import control_key, encode_control, encode_mpc_solution, mpc_key


class ControlTelemetry:
    def __init__(self, session: Any, system_id: int) -> None:
        self._control = session.declare_publisher(control_key(system_id))
        self._mpc = session.declare_publisher(mpc_key(system_id))
        self._published_solution: Any = None

    def publish(self, t: float, controller: FlightController) -> None:
        c = controller
        self._control.put(encode_control(t, c.mode, c.velocity_setpoint, c.velocity_command.euler_sp, c.command[TILTS],
                                         allocated_of(c.command), c.wrench_sp, c.residual))  # fmt: skip
        solution = c.last_mpc_solution
        if solution is not None and solution is not self._published_solution:
            self._published_solution = solution
            self._mpc.put(encode_mpc_solution(t, solution_summary(solution)))
