"""The flight controller's internals on zenoh (docs/telemetry.md): set-points, actuators, wrench and residual at
100 Hz (vtol/<sysid>/autopilot/control), and each MPC solve (vtol/<sysid>/autopilot/mpc).

In lockstep faster than real time the samples are gathered, up to BATCH_SAMPLES a payload, one JSON object a
line: every put wakes zenoh's threads here and in each subscriber, and on a machine whose cores the lockstep pair
already keeps busy those wake-ups, not the bytes, were most of what a recorded flight's telemetry cost.
Paced to the wall clock at real time, each sample goes out on its own, as it is made.
"""

from __future__ import annotations

from typing import Any

from aircraft.actuators import TILTS, allocated_of
from autopilot.control.flight_controller import FlightController
from transport.telemetry import control_key, encode_control, encode_mpc_solution, join_samples, mpc_key

BATCH_SAMPLES = 10  # 100 ms of simulated time at the velocity controller's 100 Hz


class ControlTelemetry:
    def __init__(self, session: Any, system_id: int) -> None:
        self._control = session.declare_publisher(control_key(system_id))
        self._mpc = session.declare_publisher(mpc_key(system_id))
        self._published_solution: Any = None
        self._controls: list[bytes] = []  # encoded, not yet put
        self._solutions: list[bytes] = []

    def publish(self, t: float, controller: FlightController, gather: bool = False) -> None:
        """This tick's control sample, and the MPC's solution if it is new; with `gather`, kept until
        BATCH_SAMPLES are waiting (or `flush()`), else put at once with anything waiting."""
        c = controller
        sample = encode_control(t, c.mode, c.velocity_setpoint, c.velocity_command.euler_sp, c.command[TILTS],
                                allocated_of(c.command), c.wrench_sp, c.residual)  # fmt: skip
        self._controls.append(sample)
        solution = None if c.mpc is None else c.mpc.last_solution
        if c.mpc is not None and solution is not None and solution is not self._published_solution:
            self._published_solution = solution
            self._solutions.append(encode_mpc_solution(t, c.mpc.solution_summary()))
        if not gather or len(self._controls) >= BATCH_SAMPLES:
            self.flush()

    def flush(self) -> None:
        """Put every waiting sample (one payload a key)."""
        for publisher, samples in ((self._control, self._controls), (self._mpc, self._solutions)):
            if samples:
                publisher.put(join_samples(samples))
                samples.clear()
