"""One mission flown by one controller, end to end (docs/missions.md): the plant and the autopilot
in lockstep on free ports (the public API, tiltrotor_sitl.Vehicle, speed None), the mission uploaded through the
MAVLink mission protocol by a pymavlink ground station, Mission mode, arm, flown until the vehicle disarms on
the ground; the autopilot's 100 Hz log kept. Then the per-waypoint closest approach and the landing error.

The run folder `<out>/<mission>/<controller>/` gets flight.csv (the autopilot's log), result.json, and the
processes' files under vehicle/ (replaced at each run).
"""

from __future__ import annotations

import json
import math
import shutil
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pymavlink import mavutil

from autopilot.topics.mission_items import MissionItem
from tiltrotor_sitl import Controller, Vehicle
from transport import flight_log
from transport.geodesy import Home, ned_from_geodetic
from transport.mavlink import mavlink as M

MISSION_MODE = (4, 4)  # PX4 main mode AUTO, sub-mode MISSION
GCS_SYSTEM, GCS_COMPONENT = 255, M.MAV_COMP_ID_MISSIONPLANNER
HEARTBEAT_PERIOD_S = 0.5  # wall seconds between our HEARTBEATs (the vehicle's data-link failsafe listens)
REPLY_TIMEOUT_S = 10.0
FLIGHT_TIMEOUT_S = 1200.0  # wall seconds a mission may take before the run is given up


class MissionRunFailed(RuntimeError):
    """The vehicle refused the mission, or did not finish it."""


@dataclass(frozen=True)
class WaypointResult:
    seq: int  # the item's index in the mission
    north: float
    east: float
    acceptance_m: float
    closest_m: float

    @property
    def reached(self) -> bool:
        return self.closest_m <= self.acceptance_m


@dataclass
class MissionResult:
    mission: str
    controller: str
    waypoints: list[WaypointResult]
    landing_error_m: float
    sim_s: float
    wall_s: float
    run_dir: Path

    def as_json(self) -> dict[str, Any]:
        return {"mission": self.mission, "controller": self.controller, "landing_error_m": self.landing_error_m,
                "sim_s": self.sim_s, "wall_s": self.wall_s,
                "waypoints": [{**asdict(w), "reached": w.reached} for w in self.waypoints]}  # fmt: skip


class MissionGroundStation:
    """A pymavlink ground station on the vehicle's GCS link: uploads, commands, waits, says HEARTBEAT."""

    def __init__(self, url: str, target: int) -> None:
        """`url`: where the vehicle's GCS link sends; `target`: its system id, which the requests are addressed to."""
        self.target = target
        self.conn = mavutil.mavlink_connection(url, source_system=GCS_SYSTEM, source_component=GCS_COMPONENT,
                                               dialect="common")  # fmt: skip
        self.armed = False
        self.statustexts: list[str] = []
        self._heartbeat_at = 0.0

    def close(self) -> None:
        self.conn.close()

    def receive(self, kinds: tuple[str, ...], timeout_s: float = REPLY_TIMEOUT_S) -> Any:
        """The next message of one of `kinds` (HEARTBEAT and STATUSTEXT noted on the way); MissionRunFailed if none."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if time.monotonic() - self._heartbeat_at > HEARTBEAT_PERIOD_S:
                self._heartbeat_at = time.monotonic()
                self.conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            message = self.conn.recv_match(blocking=True, timeout=0.1)
            if message is None:
                continue
            kind = message.get_type()
            if kind == "HEARTBEAT" and message.get_srcComponent() == 1:
                self.armed = bool(message.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED)
            elif kind == "STATUSTEXT":
                self.statustexts.append(message.text)
            if kind in kinds:
                return message
        raise MissionRunFailed(f"no {' or '.join(kinds)} within {timeout_s:g} s; last STATUSTEXT "
                               f"{self.statustexts[-3:]}")  # fmt: skip

    def command(self, command: int, *params: float) -> None:
        self.conn.mav.command_long_send(self.target, 1, command, 0, *params, *[0.0] * (7 - len(params)))
        while (ack := self.receive(("COMMAND_ACK",))).command != command:
            pass
        if ack.result != M.MAV_RESULT_ACCEPTED:
            raise MissionRunFailed(f"command {command} refused ({ack.result}); last STATUSTEXT {self.statustexts[-3:]}")

    def upload(self, rows: list[MissionItem]) -> None:
        """The mission protocol's upload: MISSION_COUNT, each MISSION_REQUEST_INT answered, the MISSION_ACK."""
        kind = M.MAV_MISSION_TYPE_MISSION
        self.conn.mav.mission_count_send(self.target, 1, len(rows), kind)
        while True:
            message = self.receive(("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"))
            if message.get_type() == "MISSION_ACK":
                if message.type != M.MAV_MISSION_ACCEPTED:
                    raise MissionRunFailed(f"the mission was refused: MISSION_ACK {message.type}; last STATUSTEXT "
                                           f"{self.statustexts[-3:]}")  # fmt: skip
                return
            row = rows[message.seq]
            self.conn.mav.mission_item_int_send(self.target, 1, message.seq, row.frame, row.command, int(message.seq == 0),
                                                row.autocontinue, row.param1, row.param2, row.param3, row.param4,
                                                row.x, row.y, row.z, kind)  # fmt: skip

    def parameter(self, name: str) -> float:
        self.conn.mav.param_request_read_send(self.target, 1, name.encode(), -1)
        while (value := self.receive(("PARAM_VALUE",))).param_id != name:
            pass
        return float(value.param_value)


def waypoint_results(rows: list[MissionItem], home: Home, log: flight_log.FlightLog,
                     default_acceptance: float) -> list[WaypointResult]:  # fmt: skip
    """Each NAV_WAYPOINT's closest horizontal approach in the log, with its acceptance radius (param2, else
    NAV_ACC_RAD)."""
    results = []
    for seq, row in enumerate(rows):
        if row.command != M.MAV_CMD_NAV_WAYPOINT or not row.positional:
            continue
        north, east, _ = ned_from_geodetic(home, row.latitude_deg, row.longitude_deg, home.alt)
        distance = np.hypot(log[flight_log.NORTH] - north, log[flight_log.EAST] - east)
        radius = row.param2 if math.isfinite(row.param2) and row.param2 > 0 else default_acceptance
        results.append(WaypointResult(seq, round(north, 2), round(east, 2), radius, round(float(distance.min()), 3)))
    return results


def fly_mission(rows: list[MissionItem], name: str, controller: Controller, out: Path,
                params: dict[str, float] | None = None) -> MissionResult:  # fmt: skip
    """Fly `rows` with `controller` in lockstep from the ground at home; raises MissionRunFailed."""
    run_dir = out / name / controller
    run_dir.mkdir(parents=True, exist_ok=True)
    log_path = run_dir / "flight.csv"
    log_path.unlink(missing_ok=True)
    if (run_dir / "vehicle").is_dir():
        shutil.rmtree(run_dir / "vehicle")  # a fresh vehicle each run: no parameters or mission from the last
    started = time.perf_counter()
    vehicle = Vehicle(controller=controller, speed=None, truth=False, params=params, folder=run_dir / "vehicle",
                      autopilot_args=("--log", str(log_path), "--quiet"))  # fmt: skip
    with vehicle:
        gs = MissionGroundStation(vehicle.pymavlink, vehicle.sysid)
        try:
            gs.receive(("HEARTBEAT",))
            acceptance = gs.parameter("NAV_ACC_RAD")
            gs.upload(rows)
            gs.command(M.MAV_CMD_DO_SET_MODE, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, *MISSION_MODE)
            gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
            while not gs.armed:
                gs.receive(("HEARTBEAT",))
            deadline = time.monotonic() + FLIGHT_TIMEOUT_S
            while gs.armed:
                gs.receive(("HEARTBEAT",), timeout_s=max(deadline - time.monotonic(), 0.1))
        finally:
            gs.close()
    wall_s = time.perf_counter() - started
    log = flight_log.read_flight_log(log_path)
    landing_error = float(math.hypot(log[flight_log.NORTH][-1], log[flight_log.EAST][-1]))
    result = MissionResult(name, controller, waypoint_results(rows, vehicle.home, log, acceptance),
                           round(landing_error, 3), round(float(log[flight_log.T][-1]), 2), round(wall_s, 1),
                           run_dir)  # fmt: skip
    (run_dir / "result.json").write_text(json.dumps(result.as_json(), indent=2) + "\n")
    return result
