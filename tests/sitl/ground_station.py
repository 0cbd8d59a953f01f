"""A pymavlink ground station for the tests: what a user's script does with `mavutil`, plus the simulation
clock read from the vehicle's telemetry (time_boot_ms), so a test can wait in simulated seconds."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from pymavlink import mavutil

from transport.mavlink import mavlink

TIMED = ("ATTITUDE", "ATTITUDE_QUATERNION", "LOCAL_POSITION_NED", "GLOBAL_POSITION_INT", "SYSTEM_TIME")
HOLD = (4 << 16) | (3 << 24)
TAKEOFF = (4 << 16) | (2 << 24)
LAND = (4 << 16) | (6 << 24)
OFFBOARD = 6 << 16
MODE_NAMES = {HOLD: "Hold", TAKEOFF: "Takeoff", LAND: "Land", OFFBOARD: "Offboard"}
VELOCITY_MASK = 0x9C7  # what MAVSDK sends: velocity and yaw used
MISSION_MESSAGES = ["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK", "MISSION_COUNT", "MISSION_ITEM_INT",
                    "MISSION_ITEM", "MISSION_CURRENT", "MISSION_ITEM_REACHED", "STATUSTEXT"]  # fmt: skip


class GroundStation:
    """mavutil 'udpin' connection on 127.0.0.1:port: the vehicle sends there, we answer its address."""

    def __init__(self, port: int, vehicle: int, *, system_id: int = 255, component_id: int = 190,
                 speaks_first: bool = False) -> None:  # fmt: skip
        """vehicle: the system id of the vehicle we talk to: our commands, parameters and set-points are addressed
        to it (component 1, the autopilot), and we hear only it (14550 is every vehicle's ground-station port, other
        test runs' too). speaks_first: send to 127.0.0.1:port instead (a vehicle, or a proxy in front of one, that
        learns our address from our HEARTBEATs), as MAVSDK and QGroundControl do when given the vehicle's
        address."""
        url = f"udpout:127.0.0.1:{port}" if speaks_first else f"udpin:127.0.0.1:{port}"
        self.conn = mavutil.mavlink_connection(url, source_system=system_id, source_component=component_id,
                                               dialect="common")  # fmt: skip
        self.speaks_first = speaks_first
        self.vehicle = vehicle
        self.latest: dict[str, Any] = {}
        self.statustexts: list[str] = []
        self._chunks: dict[int, dict[int, str]] = {}
        self.acks: list[Any] = []
        self.heartbeats: list[tuple[float, Any]] = []  # (sim time, HEARTBEAT)
        self.param_values: list[Any] = []
        self.time_boot_ms = 0
        self.retries = 0  # commands sent again for want of an ACK
        self._last_heartbeat = 0.0
        self.sends_heartbeats = True  # False: the ground station falls silent (a data-link loss)
        self._recordings: list[tuple[tuple[str, ...], list[Any]]] = []

    def close(self) -> None:
        self.conn.close()

    # ---- receiving ----------------------------------------------------------------------------------------
    def _note(self, message: Any) -> None:
        kind = message.get_type()
        if kind == "BAD_DATA" or message.get_srcSystem() != self.vehicle:
            return
        self.latest[kind] = message
        for kinds, got in self._recordings:
            if kind in kinds:
                got.append(message)
        if kind in TIMED:
            self.time_boot_ms = message.time_boot_ms
        elif kind == "STATUSTEXT":
            if message.id == 0:
                self.statustexts.append(message.text)
            else:  # a chunk of a longer text: the last one is shorter than 50 bytes
                parts = self._chunks.setdefault(message.id, {})
                parts[message.chunk_seq] = message.text
                if len(message.text) < 50:
                    self.statustexts.append("".join(parts[i] for i in sorted(parts)))
                    del self._chunks[message.id]
        elif kind == "COMMAND_ACK":
            self.acks.append(message)
        elif kind == "HEARTBEAT" and message.get_srcComponent() == 1:
            self.heartbeats.append((self.sim_time, message))
        elif kind == "PARAM_VALUE":
            self.param_values.append(message)

    def pump(self, timeout_s: float = 0.05) -> None:
        """Handle everything that arrives within timeout_s (wall); a HEARTBEAT each wall second, as GCSs do."""
        deadline = time.monotonic() + timeout_s
        if (
            self.sends_heartbeats
            and deadline - self._last_heartbeat > 1.0
            and ("HEARTBEAT" in self.latest or self.speaks_first)
        ):
            self.heartbeat()
        while True:
            message = self.conn.recv_match(blocking=True, timeout=max(0.0, deadline - time.monotonic()))
            if message is None:
                return
            self._note(message)
            if time.monotonic() >= deadline:
                return

    @contextmanager
    def recording(self, *kinds: str) -> Iterator[list[Any]]:
        """Every message of `kinds` from the vehicle handled while the block runs, in the order received."""
        entry: tuple[tuple[str, ...], list[Any]] = (kinds, [])
        self._recordings.append(entry)
        try:
            yield entry[1]
        finally:
            self._recordings.remove(entry)

    @property
    def sim_time(self) -> float:
        return self.time_boot_ms / 1000.0

    def wait(self, predicate: Callable[[], bool], what: str, timeout_s: float = 30.0,
             every: Callable[[], None] | None = None) -> None:  # fmt: skip
        """Pump until predicate() holds (wall timeout); `every` runs at each turn (e.g. to stream set-points)."""
        deadline = time.monotonic() + timeout_s
        while not predicate():
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out waiting for {what}; last STATUSTEXT: {self.statustexts[-5:]}")
            if every is not None:
                every()
            self.pump(0.02)

    def wait_sim(self, seconds: float, every: Callable[[], None] | None = None, timeout_s: float = 60.0) -> None:
        until = self.sim_time + seconds
        self.wait(lambda: self.sim_time >= until, f"{seconds} simulated seconds", timeout_s, every)

    def connect(self, timeout_s: float = 60.0) -> None:
        """Wait for the vehicle's HEARTBEAT, and say ours so it answers us."""
        self.wait(lambda: "HEARTBEAT" in self.latest, "the vehicle's HEARTBEAT", timeout_s)
        self.heartbeat()
        self.wait(lambda: "ATTITUDE" in self.latest, "telemetry", timeout_s, every=self.heartbeat)

    # ---- state ----------------------------------------------------------------------------------------------
    @property
    def mode(self) -> int:
        return self.latest["HEARTBEAT"].custom_mode

    @property
    def armed(self) -> bool:
        return bool(self.latest["HEARTBEAT"].base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)

    @property
    def altitude(self) -> float:
        return -self.latest["LOCAL_POSITION_NED"].z

    @property
    def velocity(self) -> tuple[float, float, float]:
        p = self.latest["LOCAL_POSITION_NED"]
        return p.vx, p.vy, p.vz

    @property
    def landed_state(self) -> int:
        return self.latest["EXTENDED_SYS_STATE"].landed_state

    # ---- sending ---------------------------------------------------------------------------------------------
    def heartbeat(self) -> None:
        self._last_heartbeat = time.monotonic()
        self.conn.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)

    def command(self, command: int, *params: float, timeout_s: float = 10.0, retry_s: float | None = None) -> Any:
        """COMMAND_LONG to the vehicle's autopilot; the COMMAND_ACK for it. retry_s: send it again (confirmation + 1) each retry_s wall
        seconds until acknowledged, as MAVSDK and QGroundControl do; `retries` counts the resends."""
        p = list(params) + [0.0] * (7 - len(params))
        start = len(self.acks)
        sent = [time.monotonic(), 0]  # when last sent, confirmation
        self.conn.mav.command_long_send(self.vehicle, 1, command, 0, *p)
        found: list[Any] = []

        def acked() -> bool:
            found.extend(a for a in self.acks[start:] if a.command == command)
            return bool(found)

        def resend() -> None:
            if retry_s is not None and time.monotonic() - sent[0] > retry_s:
                sent[0], sent[1] = time.monotonic(), min(sent[1] + 1, 255)
                self.retries += 1
                self.conn.mav.command_long_send(self.vehicle, 1, command, sent[1], *p)

        self.wait(acked, f"COMMAND_ACK for {command}", timeout_s, every=resend)
        return found[0]

    def set_mode(self, custom_mode: int) -> Any:
        return self.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                            (custom_mode >> 16) & 0xFF, (custom_mode >> 24) & 0xFF)  # fmt: skip

    def velocity_setpoint(self, vn: float, ve: float, vd: float) -> None:
        self.conn.mav.set_position_target_local_ned_send(
            self.time_boot_ms,
            self.vehicle,
            1,
            mavlink.MAV_FRAME_LOCAL_NED,
            VELOCITY_MASK,
            0,
            0,
            0,
            vn,
            ve,
            vd,
            0,
            0,
            0,
            0.0,
            0,
        )

    def param_set(self, name: str, value: float, kind: int) -> Any:
        """PARAM_SET (value already in its wire encoding); the PARAM_VALUE that answers it."""
        start = len(self.param_values)
        self.conn.mav.param_set_send(self.vehicle, 1, name.encode(), value, kind)
        found: list[Any] = []

        def answered() -> bool:
            found.extend(p for p in self.param_values[start:] if p.param_id == name)
            return bool(found)

        self.wait(answered, f"PARAM_VALUE {name}", 10.0)
        return found[0]


class MissionClient:
    """The mission side of a ground station: uploads and downloads, addressed to its vehicle, reading the mission
    messages straight from its connection."""

    def __init__(self, gs: GroundStation) -> None:
        self.gs = gs
        self.mav = gs.conn.mav
        self.statustexts: list[str] = []
        self.seen: list = []

    def next(self, *kinds: str, timeout_s: float = 15.0):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            message = self.gs.conn.recv_match(type=MISSION_MESSAGES, blocking=True, timeout=0.2)
            if message is None:
                continue
            if message.get_type() == "STATUSTEXT":
                self.statustexts.append(message.text)
            self.seen.append(message)
            if message.get_type() in kinds:
                return message
        raise AssertionError(f"no {kinds} within {timeout_s} s; STATUSTEXT {self.statustexts[-4:]}")

    def send_item(self, seq: int, row: tuple, kind: int, *, current: int = 0) -> None:
        frame, command, p1, p2, p3, p4, x, y, z = row
        self.mav.mission_item_int_send(
            self.gs.vehicle, 1, seq, frame, command, current, 1, p1, p2, p3, p4, x, y, z, kind
        )

    def upload(self, kind: int, rows: list[tuple]) -> int:
        self.mav.mission_count_send(self.gs.vehicle, 1, len(rows), kind)
        for seq, row in enumerate(rows):
            request = self.next("MISSION_REQUEST_INT", "MISSION_ACK")
            if request.get_type() == "MISSION_ACK":
                return request.type
            assert (request.seq, request.mission_type) == (seq, kind)
            self.send_item(seq, row, kind, current=int(seq == 0))
        return self.next("MISSION_ACK").type

    def download(self, kind: int) -> list:
        """As a ground station downloads: MISSION_REQUEST_LIST again every 2 s until the count comes (a request
        sent while the autopilot is (re)starting is lost with its datagram)."""
        for _ in range(7):
            self.mav.mission_request_list_send(self.gs.vehicle, 1, kind)
            try:
                count = self.next("MISSION_COUNT", timeout_s=2.0)
                break
            except AssertionError:
                continue
        else:
            raise AssertionError(f"no MISSION_COUNT for 7 requests; STATUSTEXT {self.statustexts[-4:]}")
        assert count.mission_type == kind
        items = []
        for seq in range(count.count):
            self.mav.mission_request_int_send(self.gs.vehicle, 1, seq, kind)
            items.append(self.next("MISSION_ITEM_INT"))
        self.mav.mission_ack_send(self.gs.vehicle, 1, mavlink.MAV_MISSION_ACCEPTED, kind)
        return items


def said(gs: GroundStation, text: str, since: int = 0, timeout_s: float = 30.0) -> str:
    """The first STATUSTEXT containing `text` from index `since` on, waited for."""
    gs.wait(lambda: any(text in t for t in gs.statustexts[since:]), f"the STATUSTEXT {text!r}", timeout_s)
    return next(t for t in gs.statustexts[since:] if text in t)


def distance(a: tuple[float, float], b: tuple[float, float]) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])
