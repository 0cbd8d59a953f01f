"""One campaign flight, on whichever worker runs it: the point's scenario flown as `vtol scenario` flies it
(ground_tools/scenario_run.py: the processes, MAVLink, lockstep) on a port block of its own, turned into the
store's row. A flight that cannot be flown becomes a row with status "failed" and the reason."""

from __future__ import annotations

import functools
import importlib.metadata
import socket
import subprocess
import time
import traceback
from pathlib import Path
from typing import Any

from ground_tools.campaign.points import FlightPoint
from ground_tools.campaign.spec import PLANT_AIRFRAME, autopilot_parameters, plant_wind, scenario_parameters
from ground_tools.lockstep_client import ScenarioError
from ground_tools.lockstep_flight import FlightFailed
from ground_tools.scenario_run import run_scenario
from scenarios.variants import build_scenario
from tiltrotor_sitl._port_blocks import NoFreeBlock, claim_block

FIRST_INSTANCE = 100  # flights take instances 100 .. 999: `vtol up` and tests keep the low ones
INSTANCES = 900
PACKAGE = "tiltrotor-sitl"


@functools.cache
def code_version() -> str:
    """`git describe --always --dirty` of the checkout this code runs from, else the installed package's version."""
    here = Path(__file__).resolve().parent
    try:
        described = subprocess.run(["git", "describe", "--always", "--dirty", "--tags"], cwd=here, capture_output=True,
                                   text=True, timeout=10)  # fmt: skip
        if described.returncode == 0 and described.stdout.strip():
            return f"git {described.stdout.strip()}"
    except (OSError, subprocess.TimeoutExpired):
        pass
    return f"{PACKAGE} {importlib.metadata.version(PACKAGE)}"


def flight_folder(out: Path, key: str) -> Path:
    return out / "flights" / key


def fly_point(point: FlightPoint, out: str, campaign_folder: str) -> dict[str, Any]:
    """Fly `point` into `out`/flights/<key>/; the store's row for it."""
    autopilot_params = autopilot_parameters(point.params)
    wind, turbulence, seed = plant_wind(point.params)
    scenario_params = scenario_parameters(point.params)
    row: dict[str, Any] = {"key": point.key, "scenario": point.scenario, "controller": point.controller,
                           "repetition": point.repetition, "params": point.params, "code_version": code_version(),
                           "host": socket.gethostname(), "status": "failed", "error": None, "metrics": {},
                           "sim_s": None, "wall_s": None, "run_dir": None, "failure_trigger": None}  # fmt: skip
    started = time.perf_counter()
    try:
        scenario = build_scenario(point.scenario, scenario_params)
        airframe = point.params.get(PLANT_AIRFRAME)
        plant_airframe = None if airframe is None else Path(campaign_folder) / airframe
        block = claim_block(FIRST_INSTANCE, INSTANCES, start=int(point.key, 16) % INSTANCES)
        result = run_scenario(scenario, point.controller, flight_folder(Path(out), point.key),  # type: ignore[arg-type]
                              block=block, wind_ned=wind, plant_airframe=plant_airframe, record=False,
                              autopilot_params=autopilot_params, wind_turbulence=turbulence,
                              wind_seed=seed)  # fmt: skip
    except (FlightFailed, ScenarioError, NoFreeBlock) as exc:
        row["error"] = str(exc) or type(exc).__name__
    except Exception:  # a bug must not stop the other flights: it is the row's reason, with its traceback
        row["error"] = traceback.format_exc(limit=5)
    else:
        row.update(status="done", metrics=result.metrics, sim_s=result.sim_s, run_dir=str(result.run_dir.resolve()),
                   failure_trigger=None if scenario.failure is None else scenario.failure.trigger)  # fmt: skip
    row["wall_s"] = round(time.perf_counter() - started, 3)
    return row
