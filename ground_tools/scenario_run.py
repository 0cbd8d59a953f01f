"""One scenario with one controller, end to end (docs/scenarios.md): processes, MAVLink flight, recording, run folder.

The plant (`vtol-sim`, lockstep) and the autopilot (`vtol-autopilot --offboard-lockstep`) start on free ports
(or an instance's ports), spawned hovering at 100 m. The scripted ground station (lockstep_client.py) flies the
scenario through the autopilot's API link, while a zenoh subscriber records the plant's truth and the
autopilot's control and MPC samples. The run folder `<out>/<scenario>/<controller>/` gets:

    flight.tlog        every MAVLink message sent and received (pymavlink's mavlogdump reads it)
    flight.ulg         the autopilot's ULog of the run (PX4's topics; pyulog, PlotJuggler, Flight Review read it)
    timeseries.csv     the autopilot's 100 Hz log (truth state, set-points, actuators), t = 0 at the profile start
    metrics.json       the metrics of docs/scenarios.md (ground_tools/metrics.py)
    telemetry.jsonl.gz the zenoh recording, gzip JSON lines (ground_tools/telemetry_record.py), unless --no-record
    run.json           the processes' summaries, the flight's events, ports and timings
    autopilot.log, plant.log   the processes' stderr

Both processes run in a process group of their own (a Ctrl-C in the terminal reaches only the command, whose run
kills them) and are killed (SIGKILL) by the kernel when the thread that started them ends, however it ends: the
command's, a `vtol scenario` worker's, a campaign's Dask worker's (an abandoned run has nothing to save).
"""

from __future__ import annotations

import json
import shutil
import signal
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aircraft.airframe import load_airframe
from autopilot.storage.parameters import ParameterStore
from ground_tools.lockstep_client import START_MS, LockstepClient
from ground_tools.lockstep_flight import FlightFailed
from ground_tools.metrics import detection_time, flight_metrics
from scenarios.experiments import Scenario
from tiltrotor_sitl._children import Child, Stream, start, stop
from tiltrotor_sitl._commands import AutopilotCommand, Controller, SimCommand, VehiclePorts, Zenoh
from tiltrotor_sitl._port_blocks import PortBlock
from transport.flight_log import read_flight_log, write_flight_log
from transport.ports import LOOPBACK, Ports

SPAWN_ALT_M = 100.0
PLANT_LOCKSTEP_TIMEOUT_S = 120.0  # the plant waits this long for a held autopilot before it would step on
RUN_TIMEOUT_S = 1800.0
ZENOH_CONNECT_TIMEOUT_S = 10.0
EXIT_GRACE_S = 10.0  # once one process has ended, the other gets this long to end too
VEHICLE_ROOT = "vehicle"  # the autopilot's file root within the run folder, while the run lasts
WALL_CLOCK_KEYS = ("solve_ms_median", "solve_ms_p99", "solve_ms_max")  # measurements of the machine, not the flight


def run_ports(instance: int | None) -> VehiclePorts:
    """An instance's ports (docs/plant-link.md), or free ones (so a scenario can run beside `vtol up` or another scenario)."""
    return VehiclePorts.free() if instance is None else VehiclePorts.of_instance(instance)


@dataclass
class RunResult:
    scenario: str
    controller: str
    run_dir: Path
    metrics: dict[str, Any]
    sim_s: float
    wall_s: float


def keep_ulog(root: Path, target: Path) -> None:
    """The run's ULog (its one log, from the spawn in the air to the end) moved out of the vehicle's scratch root
    to `target`, beside the .tlog; the root is removed."""
    logs = sorted((root / "log").glob("*/*.ulg"))
    if logs:
        logs[-1].replace(target)
    else:
        print(f"vtol: warning: the autopilot wrote no ULog in {root}", file=sys.stderr)
    shutil.rmtree(root, ignore_errors=True)


def write_timeseries(autopilot_log: Path, table: Path, start_s: float) -> None:
    """The autopilot's log from the profile start on, with t shifted so t = 0 is the profile start."""
    write_flight_log(table, read_flight_log(autopilot_log).since(start_s))


def write_parameters(path: Path, values: Mapping[str, float]) -> None:
    """The autopilot's parameter file holding `values` (ValueError naming a refused one; FlightFailed when it cannot
    be written)."""
    store = ParameterStore(path)
    for name, value in values.items():
        store.set(name, float(value))
    error = store.flush()
    if error:
        raise FlightFailed(f"cannot write the parameter file {path}: {error}")


def run_scenario(
    scenario: Scenario,
    controller: Controller,
    out: Path,
    *,
    instance: int | None = None,
    block: PortBlock | None = None,
    wind_ned: tuple[float, float, float] = (0.0, 0.0, 0.0),
    plant_airframe: Path | None = None,
    record: bool = True,
    on_progress: Callable[[float], None] = lambda sim_s: None,
    mpc_horizon: str | None = None,
    autopilot_params: Mapping[str, float] | None = None,
    wind_turbulence: float = 0.0,
    wind_seed: int = 0,
) -> RunResult:
    """Fly `scenario` with `controller` ("mpc" | "pid"); raises FlightFailed (or ScenarioError). The processes use
    `block`'s ports (it is closed when the run ends), else instance `instance`'s, else free ones. `wind_ned`,
    `wind_turbulence` and `wind_seed` (the plant's mean wind and its Dryden turbulence) and `plant_airframe` (model
    mismatch: the autopilot keeps the paper's airframe) go to the plant; `mpc_horizon`
    ("paper" | "long", default the autopilot's VT_MPC_HRZN) and `autopilot_params` (parameters by name: gains,
    the MPC's weights; checked, ValueError) to the autopilot, in its parameter file."""
    run_dir = out / scenario.name / controller
    run_dir.mkdir(parents=True, exist_ok=True)
    for old in (
        "params.json",
        "telemetry.jsonl.gz",
        "metrics.json",
        "run.json",
        "timeseries.csv",
        "autopilot_log.csv",
        "flight.ulg",
    ):
        (run_dir / old).unlink(missing_ok=True)
    shutil.rmtree(run_dir / VEHICLE_ROOT, ignore_errors=True)
    write_parameters(run_dir / "params.json", autopilot_params or {})
    if block is None:
        ports = run_ports(instance)
        try:
            block = PortBlock.bind(ports)
        except OSError as exc:
            raise FlightFailed(f"cannot bind UDP {LOOPBACK}:{ports.links.api_remote} for the ground station: "
                               f"{exc.strerror}") from None  # fmt: skip
    ports, gcs = block.ports, block.ground_station
    sysid = Ports(instance).system_id if instance is not None else 1  # an instance's vehicle is I + 1, as in `vtol up`
    duration_s = START_MS / 1000.0 + scenario.duration_s
    airframe = load_airframe(None)
    processes: list[Child] = []
    recorder = None
    started = time.perf_counter()
    try:
        plant_command = SimCommand(
            port=ports.plant, spawn_alt=SPAWN_ALT_M, duration_s=duration_s, lockstep_timeout_s=PLANT_LOCKSTEP_TIMEOUT_S,
            summary=True, zenoh=Zenoh.listening(ports.zenoh_plant) if record else Zenoh.off(),
            wind_ned=None if wind_ned == (0.0, 0.0, 0.0) else wind_ned, airframe=plant_airframe, sysid=sysid,
            wind_turbulence=wind_turbulence, wind_seed=wind_seed,
        )  # fmt: skip
        plant = start("vtol-sim", plant_command.argv(), stdout=Stream.CAPTURE, stderr=run_dir / "plant.log",
                      deterministic=True, own_group=True, parent_death=signal.SIGKILL)  # fmt: skip
        processes.append(plant)
        autopilot_command = AutopilotCommand(
            sim_port=ports.plant, links=ports.links, spawn_alt=SPAWN_ALT_M, controller=controller,
            mpc_horizon=mpc_horizon,
            offboard_lockstep=True, duration_s=duration_s, log=run_dir / "autopilot_log.csv", root=run_dir / VEHICLE_ROOT,
            params=run_dir / "params.json", summary=True, quiet=True, sysid=sysid,
            zenoh=Zenoh.listening(ports.zenoh_autopilot) if record else Zenoh.off(),
        )  # fmt: skip
        autopilot = start("vtol-autopilot", autopilot_command.argv(), stdout=Stream.CAPTURE,
                          stderr=run_dir / "autopilot.log", deterministic=True, own_group=True,
                          parent_death=signal.SIGKILL)  # fmt: skip
        processes.append(autopilot)

        def start_recording(hold_ms: int) -> None:
            """At the first hold: the held step's state (time_boot_ms rounds the plant's time down to 1 ms, its
            steps are 2.5 ms apart) is left out, so every run's recording starts at the step after it."""
            nonlocal recorder
            if record:
                from ground_tools.telemetry_record import TelemetryRecorder

                recorder = TelemetryRecorder([ports.zenoh_plant, ports.zenoh_autopilot], run_dir / "telemetry.jsonl.gz",
                                             sysid, plant_states_from_s=(hold_ms + 1) / 1000.0)  # fmt: skip
                recorder.start()
                if not recorder.wait_for_peers(2, ZENOH_CONNECT_TIMEOUT_S):
                    print("vtol: warning: the zenoh recorder did not connect to both processes; the recording may "
                          "be partial", file=sys.stderr)  # fmt: skip

        first_exit: list[float] = []

        def finished() -> bool:
            """Both processes have ended; one that outlives the other by EXIT_GRACE_S is killed (a plant waits
            for its autopilot, an autopilot for its plant)."""
            if time.perf_counter() - started > RUN_TIMEOUT_S:
                raise FlightFailed(f"the run took longer than {RUN_TIMEOUT_S:g} s")
            running = [process for process in processes if process.poll() is None]
            if running and len(running) < len(processes):
                if not first_exit:
                    first_exit.append(time.monotonic())
                if time.monotonic() - first_exit[0] > EXIT_GRACE_S:
                    stop(running, signal.SIGKILL)
                    return True
            return not running

        with open(run_dir / "flight.tlog", "wb") as tlog:
            client = LockstepClient(gcs, scenario, airframe, sysid, tlog=tlog, on_first_hold=start_recording,
                                    on_progress=lambda ms: on_progress(ms / 1000.0))  # fmt: skip
            events = client.run(finished)
        problems = []
        for name, process in (("autopilot", autopilot), ("plant", plant)):
            if process.returncode != 0:
                log = process.stderr_text().strip().splitlines()
                problems.append(f"{name} exited with {process.returncode}: {log[-1] if log else '(nothing on stderr)'}")
        if problems:
            raise FlightFailed("; ".join(problems) + f" (logs in {run_dir})")
        summaries = {"plant": plant.summary(), "autopilot": autopilot.summary()}
    finally:
        stop(processes, signal.SIGKILL)  # every one killed before waiting for any: an interruption leaves none running
        if recorder is not None:
            recorder.stop()
        gcs.close()
    wall_s = time.perf_counter() - started

    keep_ulog(run_dir / VEHICLE_ROOT, run_dir / "flight.ulg")
    start_s = events.profile_start_ms / 1000.0
    write_timeseries(run_dir / "autopilot_log.csv", run_dir / "timeseries.csv", start_s)
    (run_dir / "autopilot_log.csv").unlink()
    table = read_flight_log(run_dir / "timeseries.csv")
    failure_s = None if events.failure_ms is None else events.failure_ms / 1000.0 - start_s
    statustexts = [(ms / 1000.0 - start_s, text) for ms, text in events.statustexts]
    metrics = flight_metrics(table, table.modes, summaries["autopilot"].get("controller"), scenario.circle, failure_s,
                             detection_time(statustexts, failure_s))  # fmt: skip
    (run_dir / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    run = {
        "scenario": scenario.name,
        "controller": controller,
        "profile_start_s": start_s,
        "sim_s": summaries["plant"]["sim_time_s"],
        "wall_s": round(wall_s, 2),
        "failure": None if scenario.failure is None else {"trigger": scenario.failure.trigger, "t_s": failure_s},
        "plant": {
            "wind_ned": list(wind_ned),
            "wind_turbulence": wind_turbulence,
            "wind_seed": wind_seed,
            "airframe": None if plant_airframe is None else str(plant_airframe),
        },
        "autopilot_params": dict(autopilot_params or {}),
        "lockstep_intact": summaries["plant"].get("missed_commands", 0) == 0,
        "holds_answered": events.holds_answered,
        "statustexts": [list(pair) for pair in statustexts],
        "processes": summaries,
        "recording": None if recorder is None else dict(recorder.counts),
    }
    (run_dir / "run.json").write_text(json.dumps(run, indent=2) + "\n")
    if not run["lockstep_intact"]:
        print(f"vtol: warning: the plant stepped without the autopilot {summaries['plant']['missed_commands']} "
              "time(s): this run is not deterministic", file=sys.stderr)  # fmt: skip
    return RunResult(scenario.name, controller, run_dir, metrics, run["sim_s"], wall_s)
