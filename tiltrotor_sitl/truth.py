"""The plant's truth, read from the zenoh bus: what the vehicle really does, whatever its autopilot believes.

The plant publishes `vtol/<sysid>/plant/state` every physics step (one or more steps a payload, docs/telemetry.md)
and failure events on
`vtol/<sysid>/plant/events`. A `TruthFeed` is a zenoh peer session (multicast scouting off, connecting only to the
plant's loopback endpoint) that keeps the latest sample and the failures announced, and waits for conditions in
simulation time.
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from transport.telemetry import decode_plant_states, plant_events_key, plant_state_key
from transport.zenoh_bus import session_config

Vec3 = tuple[float, float, float]


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
        return [cls.from_fields(fields) for fields in decode_plant_states(payload)]

    @classmethod
    def from_fields(cls, f: dict[str, float]) -> PlantTruth:
        """One sample from its PLANT_STATE_FIELDS."""

        def many(*names: str) -> tuple[float, ...]:
            return tuple(f[name] for name in names)

        return cls(
            t=f["t"], position_ned=(f["north"], f["east"], f["down"]), velocity_ned=(f["vn"], f["ve"], f["vd"]),
            quaternion=(f["qw"], f["qx"], f["qy"], f["qz"]), body_rates=(f["p"], f["q"], f["r"]),
            rotor_speeds=many(*(f"rotor_speed{i}" for i in range(1, 5))), tilts=many(*(f"tilt{i}" for i in range(1, 5))),
            surfaces=many("aileron_left", "aileron_right", "elevator", "rudder"),
            commands=many(*(f"cmd_thrust{i}" for i in range(1, 5)), *(f"cmd_tilt{i}" for i in range(1, 5)),
                          "cmd_aileron_left", "cmd_aileron_right", "cmd_elevator", "cmd_rudder"),
            airspeed=f["airspeed"], on_ground=f["on_ground"] > 0.5,
        )  # fmt: skip


class TruthTimeout(TimeoutError):
    """A condition on the plant's truth did not hold in time."""


class TruthFeed:
    """The latest plant truth of one vehicle (system id `system_id`) from the zenoh endpoint `endpoint`."""

    def __init__(self, endpoint: str, system_id: int) -> None:
        import zenoh

        self.endpoint = endpoint
        self.system_id = system_id
        self._payload: bytes | None = None
        self._failures: list[str] = []
        self._changed = threading.Condition()
        self._session: Any = zenoh.open(session_config(listen=[], connect=[endpoint]))
        self._subscribers = [
            self._session.declare_subscriber(plant_state_key(system_id), self._on_state),
            self._session.declare_subscriber(plant_events_key(system_id), self._on_event),
        ]

    def _on_state(self, sample: Any) -> None:  # zenoh's thread: keep it short
        with self._changed:
            self._payload = sample.payload.to_bytes()
            self._changed.notify_all()

    def _on_event(self, sample: Any) -> None:
        try:
            event = json.loads(sample.payload.to_bytes())
        except ValueError:
            return
        if event.get("event") == "failure":
            with self._changed:
                self._failures.append(str(event.get("text", "")))

    def close(self) -> None:
        for subscriber in self._subscribers:
            subscriber.undeclare()
        self._session.close()

    @property
    def failures(self) -> list[str]:
        """The plant's failure announcements so far, oldest first (e.g. "rotor 1: OFF")."""
        with self._changed:
            return list(self._failures)

    def latest(self, timeout_s: float = 10.0) -> PlantTruth:
        """The newest sample (the last step of the newest payload); waits up to `timeout_s` wall seconds for the
        first one."""
        with self._changed:
            if not self._changed.wait_for(lambda: self._payload is not None, timeout_s):
                raise TruthTimeout(f"the condition did not hold within {timeout_s:g} wall seconds (vehicle "
                                   f"{self.system_id}, no plant truth received from {self.endpoint})")  # fmt: skip
            return PlantTruth.all_from_payload(self._payload)[-1]

    def wait_until(self, condition: Callable[[PlantTruth], bool], timeout_sim_s: float,
                   timeout_wall_s: float = 120.0, what: str = "the condition") -> PlantTruth:  # fmt: skip
        """Wait until `condition(truth)` holds, for at most `timeout_sim_s` of simulation time (counted from the
        first sample seen here) and `timeout_wall_s` wall seconds; returns the sample it held on, raises
        TruthTimeout naming `what` otherwise."""
        wall_deadline = time.monotonic() + timeout_wall_s
        start_t: float | None = None
        seen: bytes | None = None
        truth: PlantTruth | None = None
        with self._changed:
            while True:
                if self._payload is not None and self._payload is not seen:
                    seen = self._payload
                    for truth in PlantTruth.all_from_payload(seen):
                        start_t = truth.t if start_t is None else start_t
                        if condition(truth):
                            return truth
                    if truth.t - start_t > timeout_sim_s:
                        raise TruthTimeout(f"{what} did not hold within {timeout_sim_s:g} simulated seconds "
                                           f"(vehicle {self.system_id}, t = {truth.t:.2f} s)")  # fmt: skip
                left = wall_deadline - time.monotonic()
                if left <= 0:
                    where = "no plant truth received" if truth is None else f"last t = {truth.t:.2f} s"
                    raise TruthTimeout(f"{what} did not hold within {timeout_wall_s:g} wall seconds (vehicle "
                                       f"{self.system_id}, {where} from {self.endpoint})")  # fmt: skip
                self._changed.wait(min(left, 0.5))
