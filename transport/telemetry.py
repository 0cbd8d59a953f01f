"""zenoh key expressions and payload layouts: each key function's docstring says what its payload holds
(docs/reference/zenoh.md lists them; docs/telemetry.md says how to subscribe, record and watch).

A payload of the two autopilot keys control and mpc holds one or more samples, one JSON object a line
(`join_samples`).
"""

from __future__ import annotations

import numpy as np
import orjson

PLANT_STATE_FIELDS: tuple[str, ...] = (
    ("t",)
    + ("north", "east", "down", "vn", "ve", "vd", "qw", "qx", "qy", "qz", "p", "q", "r")
    + tuple(f"rotor_speed{i}" for i in range(1, 5))
    + tuple(f"tilt{i}" for i in range(1, 5))
    + ("aileron_left", "aileron_right", "elevator", "rudder")
    + ("accel_x", "accel_y", "accel_z", "airspeed", "on_ground")
    + tuple(f"cmd_thrust{i}" for i in range(1, 5))
    + tuple(f"cmd_tilt{i}" for i in range(1, 5))
    + ("cmd_aileron_left", "cmd_aileron_right", "cmd_elevator", "cmd_rudder")
)


def plant_state_key(system_id: int) -> str:
    """The plant's state every physics step (400 Hz): little-endian float64 values in PLANT_STATE_FIELDS order, one
    or more consecutive steps a payload (up to PLANT_STATE_BATCH_STEPS)."""
    return f"vtol/{system_id}/plant/state"


def plant_events_key(system_id: int) -> str:
    """The plant's events as JSON, e.g. {"t": 12.5, "event": "failure", "text": "rotor 1: OFF"} (t: simulation s)."""
    return f"vtol/{system_id}/plant/events"


def autopilot_events_key(system_id: int) -> str:
    """The autopilot's STATUSTEXTs as JSON, e.g. {"t": 3.2, "event": "statustext", "text": "Armed", "severity": 6}."""
    return f"vtol/{system_id}/autopilot/events"


PLANT_STATE_BYTES = 8 * len(PLANT_STATE_FIELDS)
# One put per physics step woke zenoh's threads 400 times a simulated second, a quarter of a recorded lockstep
# flight's wall time on 2 cores; 10 steps is 25 ms of simulated time.
PLANT_STATE_BATCH_STEPS = 10


def encode_plant_state(
    t: float, state: np.ndarray, specific_force: np.ndarray, airspeed: float, on_ground: float, command: np.ndarray
) -> bytes:
    """One sample's payload."""
    batch = PlantStateBatch(1)
    batch.add(t, state, specific_force, airspeed, on_ground, command)
    return batch.take()


class PlantStateBatch:
    """Consecutive plant state samples gathered for one payload (at most `capacity`)."""

    def __init__(self, capacity: int = PLANT_STATE_BATCH_STEPS) -> None:
        self._rows = np.empty((capacity, len(PLANT_STATE_FIELDS)), dtype="<f8")
        self._count = 0
        # where the specific force, the airspeed, on-ground and the command begin (the state: from column 1)
        self._columns = [PLANT_STATE_FIELDS.index(f) for f in ("accel_x", "airspeed", "on_ground", "cmd_thrust1")]

    def __len__(self) -> int:
        return self._count

    @property
    def full(self) -> bool:
        return self._count == len(self._rows)

    def add(
        self, t: float, state: np.ndarray, specific_force: np.ndarray, airspeed: float, on_ground: float,
        command: np.ndarray,
    ) -> None:  # fmt: skip
        """Append one sample; the batch must not be full."""
        row = self._rows[self._count]
        force, air, ground, commands = self._columns
        row[0] = t
        row[1:force] = state
        row[force:air] = specific_force
        row[air] = airspeed
        row[ground] = on_ground
        row[commands:] = command
        self._count += 1

    def take(self) -> bytes:
        """The samples gathered so far as one payload; the batch is empty afterwards."""
        payload = self._rows[: self._count].tobytes()
        self._count = 0
        return payload


def plant_state_rows(payload: bytes) -> np.ndarray:
    """The plant state samples of a payload, a row each (PLANT_STATE_FIELDS), oldest first."""
    if not payload or len(payload) % PLANT_STATE_BYTES:
        raise ValueError(f"plant state payload has {len(payload)} bytes, expected a multiple of {PLANT_STATE_BYTES}")
    return np.frombuffer(payload, dtype="<f8").reshape(-1, len(PLANT_STATE_FIELDS))


def decode_plant_states(payload: bytes) -> list[dict[str, float]]:
    """Field name -> value of each plant state sample in a payload, oldest first."""
    return [dict(zip(PLANT_STATE_FIELDS, row)) for row in plant_state_rows(payload).tolist()]


# The JSON payloads are written by orjson: at 100 Hz the MPC's prediction (about 190 numbers) took json.dumps 93 us a
# sample and orjson 6 us, on the cores the lockstep pair flies on. Compact separators; a
# non-finite number is written as null (JSON has no NaN).


def join_samples(samples: list[bytes]) -> bytes:
    """One payload of several JSON samples, oldest first, one a line (orjson never writes a newline)."""
    return b"\n".join(samples)


def encode_event(t: float, event: str, text: str, **fields: int | float | str) -> bytes:
    """An event of plant/events or autopilot/events: {"t": <sim s>, "event": ..., "text": ..., **fields}."""
    return orjson.dumps({"t": t, "event": event, "text": text, **fields})


def control_key(system_id: int) -> str:
    """The flight controller at 100 Hz, JSON lines: t, the controller's mode, velocity_sp, euler_sp, tilt_cmd, the
    allocated actuators u (8), wrench_sp and the allocation's residual (SI units, angles in rad)."""
    return f"vtol/{system_id}/autopilot/control"


def encode_control(
    t: float,
    mode: str,
    velocity_sp: np.ndarray,
    euler_sp: np.ndarray,
    tilt_cmd: np.ndarray,
    actuators: np.ndarray,
    wrench_sp: np.ndarray,
    residual: np.ndarray,
) -> bytes:
    """One autopilot control sample as JSON (SI units, angles in rad)."""
    return orjson.dumps(
        {
            "t": t,
            "mode": mode,
            "velocity_sp": velocity_sp.tolist(),
            "euler_sp": euler_sp.tolist(),
            "tilt_cmd": tilt_cmd.tolist(),
            "u": actuators.tolist(),
            "wrench_sp": wrench_sp.tolist(),
            "residual": residual.tolist(),
        }
    )


def mpc_key(system_id: int) -> str:
    """Each MPC solve (100 Hz, the MPC flying), JSON lines: t, ok, status, solve_time_ms, qp_iterations, cost,
    predicted_velocity (N+1 x 3, NED m/s), predicted_tilt (N+1 x 4, rad), thrust (4, N) and attitude_sp (3, rad) of the
    first stage."""
    return f"vtol/{system_id}/autopilot/mpc"


def encode_mpc_solution(t: float, summary: dict) -> bytes:
    return orjson.dumps({"t": t, **summary})


# Every key the processes publish (the reference docs list them).
KEY_EXPRESSIONS = (plant_state_key, plant_events_key, autopilot_events_key, control_key, mpc_key)
