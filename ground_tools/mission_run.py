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
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from autopilot.topics.mission_items import MissionItem
from tiltrotor_sitl import CommandError, Controller, FlightMode, GroundStation, ProcessOptions, Vehicle
from transport import flight_log
from transport.geodesy import Home, ned_from_geodetic
from transport.mavlink import mavlink as M

PROGRESS_PERIOD_S = 1.0  # wall seconds between progress reports (a HEARTBEAT comes each simulated second)
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
                params: dict[str, float] | None = None,
                on_progress: Callable[[float, int], None] = lambda sim_s, item: None) -> MissionResult:  # fmt: skip
    """Fly `rows` with `controller` in lockstep from the ground at home; raises MissionRunFailed. `on_progress`
    hears the simulated seconds and the mission item being flown at each HEARTBEAT (each simulated second)."""
    run_dir = out / name / controller
    run_dir.mkdir(parents=True, exist_ok=True)
    log_path = run_dir / "flight.csv"
    log_path.unlink(missing_ok=True)
    if (run_dir / "vehicle").is_dir():
        shutil.rmtree(run_dir / "vehicle")  # a fresh vehicle each run: no parameters or mission from the last
    started = time.perf_counter()
    vehicle = Vehicle(controller=controller, speed=None, truth=False, params=params, folder=run_dir / "vehicle",
                      processes=ProcessOptions(autopilot_args=("--log", str(log_path), "--quiet")))  # fmt: skip
    with vehicle:
        try:
            acceptance = _fly(vehicle.ground_station, rows, on_progress)
        except (CommandError, TimeoutError) as exc:
            raise MissionRunFailed(str(exc)) from None
    wall_s = time.perf_counter() - started
    log = flight_log.read_flight_log(log_path)
    landing_error = float(math.hypot(log[flight_log.NORTH][-1], log[flight_log.EAST][-1]))
    result = MissionResult(name, controller, waypoint_results(rows, vehicle.home, log, acceptance),
                           round(landing_error, 3), round(float(log[flight_log.T][-1]), 2), round(wall_s, 1),
                           run_dir)  # fmt: skip
    (run_dir / "result.json").write_text(json.dumps(result.as_json(), indent=2) + "\n")
    return result


def _fly(gcs: GroundStation, rows: list[MissionItem], on_progress: Callable[[float, int], None]) -> float:
    """Upload the mission, fly it in Mission mode from the ground until the vehicle disarms; NAV_ACC_RAD (m)."""
    acceptance = gcs.get_parameter("NAV_ACC_RAD")
    gcs.upload_mission(rows)
    gcs.set_mode(FlightMode.MISSION)
    gcs.arm()
    gcs.wait_message("HEARTBEAT", lambda heartbeat: _armed(heartbeat))
    deadline = time.monotonic() + FLIGHT_TIMEOUT_S
    while (heartbeat := gcs.next_message("HEARTBEAT", timeout_s=PROGRESS_PERIOD_S)) is None or _armed(heartbeat):
        attitude, current = gcs.latest("ATTITUDE"), gcs.latest("MISSION_CURRENT")
        on_progress(attitude.time_boot_ms / 1000.0 if attitude else 0.0, current.seq if current else 0)
        if time.monotonic() > deadline:
            raise MissionRunFailed(f"still flying after {FLIGHT_TIMEOUT_S:g} wall seconds; last STATUSTEXT "
                                   f"{gcs.statustexts[-3:]}")  # fmt: skip
    return acceptance


def _armed(heartbeat: Any) -> bool:
    return bool(heartbeat.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED)
