"""The plant's truth, read from the zenoh bus: what the vehicle really does, whatever its autopilot believes.

The plant publishes `vtol/<sysid>/plant/state` every physics step (one or more steps a payload, docs/telemetry.md)
and failure events on `vtol/<sysid>/plant/events`. A `TruthFeed` is a zenoh peer session (multicast scouting off,
connecting only to the plant's loopback endpoint) that records every sample it receives in its `TruthHistory`,
and the failures announced. The history answers after the fact (the highest sample, the first time a condition
held, the trajectory as numpy arrays) and waits for conditions in simulation time, seeing every sample.
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from transport.telemetry import PLANT_STATE_FIELDS, plant_events_key, plant_state_key, plant_state_rows
from transport.zenoh_bus import session_config

Vec3 = tuple[float, float, float]
COLUMN = {name: index for index, name in enumerate(PLANT_STATE_FIELDS)}
INITIAL_ROWS = 4096  # the history's first allocation (10 simulated seconds); it doubles when full


def _columns(*names: str) -> list[int]:
    return [COLUMN[name] for name in names]


POSITION = _columns("north", "east", "down")
VELOCITY = _columns("vn", "ve", "vd")
QUATERNION = _columns("qw", "qx", "qy", "qz")
BODY_RATES = _columns("p", "q", "r")
ROTOR_SPEEDS = _columns(*(f"rotor_speed{i}" for i in range(1, 5)))
TILTS = _columns(*(f"tilt{i}" for i in range(1, 5)))
SURFACES = _columns("aileron_left", "aileron_right", "elevator", "rudder")
COMMANDS = _columns(*(f"cmd_thrust{i}" for i in range(1, 5)), *(f"cmd_tilt{i}" for i in range(1, 5)),
                    "cmd_aileron_left", "cmd_aileron_right", "cmd_elevator", "cmd_rudder")  # fmt: skip


@dataclass(frozen=True)
class PlantTruth:
    """One physics step of the plant, SI units, NED (relative to the vehicle's home) and body FRD axes."""

    t: float  # simulation time, s
    position_ned: Vec3  # m
    velocity_ned: Vec3  # m/s
    quaternion: tuple[float, float, float, float]  # w, x, y, z (body to NED)
    body_rates: Vec3  # p, q, r, rad/s
    rotor_speeds: tuple[float, ...]  # rad/s, rotors 1-4
    tilts: tuple[float, ...]  # rad, tilt servos 1-4 (0 up, pi/2 forward)
    surfaces: tuple[float, ...]  # aileron left, aileron right, elevator, rudder (-1 .. 1)
    commands: tuple[float, ...]  # the autopilot's 12 commands as the plant applied them (normalised)
    airspeed: float  # m/s
    on_ground: bool

    @property
    def altitude(self) -> float:
        """Height above home, m (= -down)."""
        return -self.position_ned[2]

    @property
    def euler(self) -> Vec3:
        """Roll, pitch, yaw (rad, ZYX) of the quaternion."""
        w, x, y, z = self.quaternion
        roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
        pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
        yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        return roll, pitch, yaw

    @classmethod
    def all_from_payload(cls, payload: bytes) -> list[PlantTruth]:
        """The samples of one payload, oldest first."""
        return [cls.from_row(row) for row in plant_state_rows(payload).tolist()]

    @classmethod
    def from_fields(cls, fields: dict[str, float]) -> PlantTruth:
        """One sample from its PLANT_STATE_FIELDS by name."""
        return cls.from_row([fields[name] for name in PLANT_STATE_FIELDS])

    @classmethod
    def from_row(cls, row: list[float]) -> PlantTruth:
        """One sample from its values in PLANT_STATE_FIELDS order."""

        def pick(columns: list[int]) -> tuple[float, ...]:
            return tuple(row[column] for column in columns)

        north, east, down = pick(POSITION)
        vn, ve, vd = pick(VELOCITY)
        w, x, y, z = pick(QUATERNION)
        p, q, r = pick(BODY_RATES)
        return cls(
            t=row[COLUMN["t"]], position_ned=(north, east, down), velocity_ned=(vn, ve, vd), quaternion=(w, x, y, z),
            body_rates=(p, q, r), rotor_speeds=pick(ROTOR_SPEEDS), tilts=pick(TILTS), surfaces=pick(SURFACES),
            commands=pick(COMMANDS), airspeed=row[COLUMN["airspeed"]], on_ground=row[COLUMN["on_ground"]] > 0.5,
        )  # fmt: skip


class Trajectory:
    """Samples of the plant's truth as numpy arrays, one row a physics step, oldest first (SI units, NED from home,
    body FRD axes, as PlantTruth)."""

    def __init__(self, rows: np.ndarray) -> None:
        self.rows = rows  # (steps, len(PLANT_STATE_FIELDS)), in PLANT_STATE_FIELDS order

    def __len__(self) -> int:
        return len(self.rows)

    def column(self, name: str) -> np.ndarray:
        """One field of PLANT_STATE_FIELDS (docs/telemetry.md), e.g. "accel_z" (m/s^2) or "cmd_thrust1"."""
        return self.rows[:, COLUMN[name]]

    def sample(self, index: int) -> PlantTruth:
        return PlantTruth.from_row(self.rows[index].tolist())

    @property
    def t(self) -> np.ndarray:
        """Simulation time, s."""
        return self.column("t")

    @property
    def position_ned(self) -> np.ndarray:
        """(steps, 3), m."""
        return self.rows[:, POSITION]

    @property
    def altitude(self) -> np.ndarray:
        """Height above home, m."""
        return -self.column("down")

    @property
    def velocity_ned(self) -> np.ndarray:
        """(steps, 3), m/s."""
        return self.rows[:, VELOCITY]

    @property
    def quaternion(self) -> np.ndarray:
        """(steps, 4): w, x, y, z, body to NED."""
        return self.rows[:, QUATERNION]

    @property
    def euler(self) -> np.ndarray:
        """(steps, 3): roll, pitch, yaw, rad (ZYX)."""
        w, x, y, z = self.quaternion.T
        roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
        pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
        yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        return np.column_stack([roll, pitch, yaw])

    @property
    def body_rates(self) -> np.ndarray:
        """(steps, 3): p, q, r, rad/s."""
        return self.rows[:, BODY_RATES]

    @property
    def rotor_speeds(self) -> np.ndarray:
        """(steps, 4), rad/s."""
        return self.rows[:, ROTOR_SPEEDS]

    @property
    def tilts(self) -> np.ndarray:
        """(steps, 4), rad (0 up, pi/2 forward)."""
        return self.rows[:, TILTS]

    @property
    def airspeed(self) -> np.ndarray:
        """m/s."""
        return self.column("airspeed")

    @property
    def on_ground(self) -> np.ndarray:
        """bool."""
        return self.column("on_ground") > 0.5


class TruthTimeout(TimeoutError):
    """A condition on the plant's truth did not hold in time."""


class TruthHistory:
    """Every sample of one vehicle's truth received since the start or since the last `mark()`, in the order they
    arrived (the plant's order), for questions after the fact and for waits that see every sample.

    It holds them all in memory: 344 bytes a physics step, so 138 kB a simulated second and 8.3 MB a simulated
    minute at the plant's 400 Hz; `mark()` lets go of what came before."""

    def __init__(self, system_id: int, source: str) -> None:
        """system_id, source: the vehicle's and where the samples come from, for the errors' texts."""
        self.system_id = system_id
        self.source = source
        self._rows = np.empty((INITIAL_ROWS, len(PLANT_STATE_FIELDS)))
        self._count = 0  # rows held
        self._dropped = 0  # samples let go by mark(): the first row held is sample number _dropped
        self._changed = threading.Condition()

    # ---- filling -------------------------------------------------------------------------------------------------
    def extend(self, rows: np.ndarray) -> None:
        """Append samples (rows in PLANT_STATE_FIELDS order, oldest first) and wake the waits."""
        with self._changed:
            needed = self._count + len(rows)
            if needed > len(self._rows):
                grown = np.empty((max(needed, 2 * len(self._rows)), len(PLANT_STATE_FIELDS)))
                grown[: self._count] = self._rows[: self._count]
                self._rows = grown
            self._rows[self._count : needed] = rows
            self._count = needed
            self._changed.notify_all()

    def mark(self) -> None:
        """Let go of every sample so far: queries and `include_past` waits start from here."""
        with self._changed:
            self._dropped += self._count
            self._rows = np.empty((INITIAL_ROWS, len(PLANT_STATE_FIELDS)))
            self._count = 0

    def __len__(self) -> int:
        """The samples held."""
        with self._changed:
            return self._count

    # ---- after the fact --------------------------------------------------------------------------------------------
    def trajectory(self) -> Trajectory:
        """The samples held, as numpy arrays (a copy)."""
        with self._changed:
            return Trajectory(self._rows[: self._count].copy())

    def samples(self) -> Iterator[PlantTruth]:
        """The samples held, oldest first (those that arrive meanwhile are not included)."""
        trajectory = self.trajectory()
        return (PlantTruth.from_row(row) for row in trajectory.rows.tolist())

    def max(self, key: Callable[[PlantTruth], float]) -> PlantTruth:
        """The sample where `key` is largest (the first of equals), e.g. max(lambda s: s.altitude); ValueError if no
        sample has arrived."""
        return max(self._nonempty(), key=key)

    def min(self, key: Callable[[PlantTruth], float]) -> PlantTruth:
        """The sample where `key` is smallest (the first of equals); ValueError if no sample has arrived."""
        return min(self._nonempty(), key=key)

    def first(self, condition: Callable[[PlantTruth], bool]) -> PlantTruth | None:
        """The first sample `condition` held on, or None."""
        return next((sample for sample in self.samples() if condition(sample)), None)

    def _nonempty(self) -> Iterator[PlantTruth]:
        if not len(self):
            raise ValueError(f"no plant truth received yet (vehicle {self.system_id}, {self.source})")
        return self.samples()

    # ---- waiting ---------------------------------------------------------------------------------------------------
    def latest(self, timeout_s: float = 10.0) -> PlantTruth:
        """The newest sample; waits up to `timeout_s` wall seconds for the first one."""
        with self._changed:
            if not self._changed.wait_for(lambda: self._count > 0, timeout_s):
                raise TruthTimeout(f"no plant truth within {timeout_s:g} wall seconds (vehicle {self.system_id}, "
                                   f"from {self.source})")  # fmt: skip
            return PlantTruth.from_row(self._rows[self._count - 1].tolist())

    def wait_until(self, condition: Callable[[PlantTruth], bool], timeout_sim_s: float,
                   timeout_wall_s: float = 120.0, what: str = "the condition",
                   include_past: bool = False) -> PlantTruth:  # fmt: skip
        """Wait until `condition(sample)` holds and return that sample. Every sample is seen, in order: those that
        arrive from now on, and with `include_past` also those held from before the call (since the start or the
        mark), so a condition that held for a single physics step is found. At most `timeout_sim_s` of simulation
        time (from the newest sample at the call) and `timeout_wall_s` wall seconds; TruthTimeout naming `what`
        otherwise."""
        wall_deadline = time.monotonic() + timeout_wall_s
        with self._changed:
            start_t = float(self._rows[self._count - 1, COLUMN["t"]]) if self._count else None
            next_sample = self._dropped if include_past else self._dropped + self._count
        last_t: float | None = None
        while True:
            with self._changed:
                next_sample = max(next_sample, self._dropped)  # a mark() meanwhile
                rows = self._rows[next_sample - self._dropped : self._count].tolist()
                next_sample += len(rows)
            for row in rows:
                sample = PlantTruth.from_row(row)
                if condition(sample):
                    return sample
                start_t = sample.t if start_t is None else start_t
                last_t = sample.t
            if last_t is not None and start_t is not None and last_t - start_t > timeout_sim_s:
                raise TruthTimeout(f"{what} did not hold within {timeout_sim_s:g} simulated seconds (vehicle "
                                   f"{self.system_id}, t = {last_t:.2f} s)")  # fmt: skip
            left = wall_deadline - time.monotonic()
            if left <= 0:
                where = "no plant truth received" if last_t is None else f"last t = {last_t:.2f} s"
                raise TruthTimeout(f"{what} did not hold within {timeout_wall_s:g} wall seconds (vehicle "
                                   f"{self.system_id}, {where} from {self.source})")  # fmt: skip
            with self._changed:
                self._changed.wait_for(lambda: self._dropped + self._count > next_sample, min(left, 0.5))


class TruthFeed(TruthHistory):
    """The plant truth of one vehicle (system id `system_id`) from the zenoh endpoint `endpoint`: every sample
    since the subscription (once the vehicle was ready) in its history, and the failures the plant announced.

    The plant publishes with zenoh's congestion control DROP: a process too busy to take the samples in loses some,
    the plant does not slow down (docs/telemetry.md). Close it (`close()`, or use it in a `with`): its zenoh
    session's threads keep the interpreter from exiting until then."""

    def __init__(self, endpoint: str, system_id: int) -> None:
        import zenoh

        super().__init__(system_id, endpoint)
        self.endpoint = endpoint
        self._failures: list[str] = []
        self.malformed = 0  # state payloads that were not whole plant states (counted, not recorded)
        self._session: Any = zenoh.open(session_config(listen=[], connect=[endpoint]))
        self._subscribers = [
            self._session.declare_subscriber(plant_state_key(system_id), self._on_state),
            self._session.declare_subscriber(plant_events_key(system_id), self._on_event),
        ]

    def _on_state(self, sample: Any) -> None:  # zenoh's thread: keep it short
        try:
            rows = plant_state_rows(sample.payload.to_bytes())
        except ValueError:
            with self._changed:
                self.malformed += 1
            return
        self.extend(rows)

    def _on_event(self, sample: Any) -> None:
        try:
            event = json.loads(sample.payload.to_bytes())
        except ValueError:
            return
        if isinstance(event, dict) and event.get("event") == "failure":
            with self._changed:
                self._failures.append(str(event.get("text", "")))

    def close(self) -> None:
        for subscriber in self._subscribers:
            subscriber.undeclare()
        self._session.close()

    def __enter__(self) -> TruthFeed:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    @property
    def failures(self) -> list[str]:
        """The plant's failure announcements so far, oldest first (e.g. "rotor 1: OFF")."""
        with self._changed:
            return list(self._failures)
