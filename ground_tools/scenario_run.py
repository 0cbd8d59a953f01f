"""One scenario with one controller, end to end (SPEC 7): processes, MAVLink flight, recording, run folder.

The plant (`vtol-sim`, lockstep) and the autopilot (`vtol-autopilot --offboard-lockstep`) start on free ports
(or an instance's ports), spawned hovering at 100 m. The scripted ground station (lockstep_client.py) flies the
scenario through the autopilot's API link, while a zenoh subscriber records the plant's truth and the
autopilot's control and MPC samples. The run folder `<out>/<scenario>/<controller>/` gets:

    flight.tlog        every MAVLink message sent and received (pymavlink's mavlogdump reads it)
    timeseries.csv     the autopilot's 100 Hz log (truth state, set-points, actuators), t = 0 at the profile start
    metrics.json       SPEC 7's metrics (ground_tools/metrics.py)
    telemetry.jsonl.gz the zenoh recording, gzip JSON lines (ground_tools/telemetry_record.py), unless --no-record
    run.json           the processes' summaries, the flight's events, ports and timings
    autopilot.log, plant.log   the processes' stderr
"""

from __future__ import annotations

import csv
import json
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aircraft.airframe import load_airframe
from ground_tools.figures import read_log
from ground_tools.lockstep_client import START_MS, LockstepClient
from ground_tools.lockstep_flight import FlightFailed, free_tcp_port, free_udp_port
from ground_tools.metrics import flight_metrics
from ground_tools.scenarios import Scenario
from transport.ports import LOOPBACK, Ports

SPAWN_ALT_M = 100.0
PLANT_LOCKSTEP_TIMEOUT_S = 120.0  # the plant waits this long for a held autopilot before it would step on
RUN_TIMEOUT_S = 1800.0
ZENOH_CONNECT_TIMEOUT_S = 10.0
EXIT_GRACE_S = 10.0  # once one process has ended, the other gets this long to end too
WALL_CLOCK_KEYS = ("solve_ms_median", "solve_ms_p99", "solve_ms_max")  # measurements of the machine, not the flight


@dataclass(frozen=True)
class RunPorts:
    plant: int
    gcs_bind: int
    gcs_remote: int
    api_bind: int
    api_remote: int  # the scripted ground station binds this
    zenoh_plant: str
    zenoh_autopilot: str


def run_ports(instance: int | None) -> RunPorts:
    """An instance's ports (SPEC 2), or free ones (so a scenario can run beside `vtol up` or another scenario)."""
    if instance is not None:
        p = Ports(instance)
        return RunPorts(p.plant, p.gcs_bind, p.gcs_remote, p.api_bind, p.api_remote, p.zenoh_plant, p.zenoh_autopilot)
    return RunPorts(free_udp_port(), free_udp_port(), free_udp_port(), free_udp_port(), free_udp_port(),
                    f"tcp/{LOOPBACK}:{free_tcp_port()}", f"tcp/{LOOPBACK}:{free_tcp_port()}")  # fmt: skip


@dataclass
class RunResult:
    scenario: str
    controller: str
    run_dir: Path
    metrics: dict[str, Any]
    sim_s: float
    wall_s: float


def _read_modes(path: Path) -> list[str]:
    with open(path, newline="") as handle:
        return [row["mode"] for row in csv.DictReader(handle)]


def write_timeseries(autopilot_log: Path, table: Path, start_s: float) -> None:
    """The autopilot's log from the profile start on, with t shifted so t = 0 is the profile start."""
    with open(autopilot_log, newline="") as source, open(table, "w", newline="") as target:
        reader, writer = csv.reader(source), csv.writer(target)
        header = next(reader)
        writer.writerow(header)
        for row in reader:
            t = float(row[0]) - start_s
            if t >= -1e-9:
                writer.writerow([f"{max(t, 0.0):.4f}", *row[1:]])


def run_scenario(
    scenario: Scenario,
    controller: str,
    out: Path,
    *,
    instance: int | None = None,
    record: bool = True,
    on_progress: Callable[[float], None] = lambda sim_s: None,
) -> RunResult:
    """Fly `scenario` with `controller` ("mpc" | "pid"); raises FlightFailed (or ScenarioError)."""
    run_dir = out / scenario.name / controller
    run_dir.mkdir(parents=True, exist_ok=True)
    for old in ("params.json", "telemetry.jsonl.gz", "metrics.json", "run.json", "timeseries.csv", "autopilot_log.csv"):
        (run_dir / old).unlink(missing_ok=True)
    ports = run_ports(instance)
    duration_s = START_MS / 1000.0 + scenario.duration_s
    airframe = load_airframe(None)
    zenoh = ("--zenoh-listen", ports.zenoh_plant) if record else ("--no-zenoh",)
    gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        gcs.bind((LOOPBACK, ports.api_remote))
    except OSError as exc:
        gcs.close()
        raise FlightFailed(f"cannot bind UDP {LOOPBACK}:{ports.api_remote} for the ground station: {exc.strerror}")
    plant_err, autopilot_err = open(run_dir / "plant.log", "w"), open(run_dir / "autopilot.log", "w")
    processes: list[subprocess.Popen] = []
    recorder = None
    started = time.perf_counter()
    try:
        plant = subprocess.Popen(
            [sys.executable, "-m", "sim_bridge", "--port", str(ports.plant), "--spawn-alt", str(SPAWN_ALT_M),
             "--duration", str(duration_s), "--lockstep-timeout", str(PLANT_LOCKSTEP_TIMEOUT_S), "--summary", *zenoh],
            stdout=subprocess.PIPE, stderr=plant_err, text=True,
        )  # fmt: skip
        processes.append(plant)
        zenoh = ("--zenoh-listen", ports.zenoh_autopilot) if record else ("--no-zenoh",)
        autopilot = subprocess.Popen(
            [sys.executable, "-m", "autopilot", "--sim-port", str(ports.plant), "--spawn-alt", str(SPAWN_ALT_M),
             "--controller", controller, "--offboard-lockstep", "--duration", str(duration_s),
             "--log", str(run_dir / "autopilot_log.csv"), "--params", str(run_dir / "params.json"),
             "--gcs-port", str(ports.gcs_bind), "--gcs-remote-port", str(ports.gcs_remote),
             "--api-port", str(ports.api_bind), "--api-remote-port", str(ports.api_remote),
             "--summary", "--quiet", *zenoh],
            stdout=subprocess.PIPE, stderr=autopilot_err, text=True,
        )  # fmt: skip
        processes.append(autopilot)

        def start_recording() -> None:
            nonlocal recorder
            if record:
                from ground_tools.telemetry_record import TelemetryRecorder

                recorder = TelemetryRecorder([ports.zenoh_plant, ports.zenoh_autopilot], run_dir / "telemetry.jsonl.gz")
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
                    for process in running:
                        process.kill()
                        process.wait()
                    return True
            return not running

        with open(run_dir / "flight.tlog", "wb") as tlog:
            client = LockstepClient(gcs, scenario, airframe, tlog=tlog, on_first_hold=start_recording,
                                    on_progress=lambda ms: on_progress(ms / 1000.0))  # fmt: skip
            events = client.run(finished)
        problems = []
        for name, process in (("autopilot", autopilot), ("plant", plant)):
            if process.returncode != 0:
                log = (run_dir / f"{name}.log").read_text().strip().splitlines()
                problems.append(f"{name} exited with {process.returncode}: {log[-1] if log else '(nothing on stderr)'}")
        if problems:
            raise FlightFailed("; ".join(problems) + f" (logs in {run_dir})")
        summaries = {name: json.loads(process.stdout.read().strip().splitlines()[-1])
                     for name, process in (("plant", plant), ("autopilot", autopilot))}  # fmt: skip
    finally:
        for process in processes:
            if process.poll() is None:
                process.kill()
            process.wait()
            if process.stdout:
                process.stdout.close()
        if recorder is not None:
            recorder.stop()
        gcs.close()
        plant_err.close()
        autopilot_err.close()
    wall_s = time.perf_counter() - started

    start_s = events.profile_start_ms / 1000.0
    write_timeseries(run_dir / "autopilot_log.csv", run_dir / "timeseries.csv", start_s)
    (run_dir / "autopilot_log.csv").unlink()
    table = read_log(run_dir / "timeseries.csv")
    failure_s = None if events.failure_ms is None else events.failure_ms / 1000.0 - start_s
    metrics = flight_metrics(table, _read_modes(run_dir / "timeseries.csv"), summaries["autopilot"].get("controller"),
                             scenario.circle, failure_s)  # fmt: skip
    (run_dir / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    run = {
        "scenario": scenario.name,
        "controller": controller,
        "profile_start_s": start_s,
        "sim_s": summaries["plant"]["sim_time_s"],
        "wall_s": round(wall_s, 2),
        "failure": None if scenario.failure is None else {"trigger": scenario.failure.trigger, "t_s": failure_s},
        "lockstep_intact": summaries["plant"].get("missed_commands", 0) == 0,
        "holds_answered": events.holds_answered,
        "statustexts": [[ms / 1000.0 - start_s, text] for ms, text in events.statustexts],
        "processes": summaries,
        "recording": None if recorder is None else dict(recorder.counts),
    }
    (run_dir / "run.json").write_text(json.dumps(run, indent=2) + "\n")
    if not run["lockstep_intact"]:
        print(f"vtol: warning: the plant stepped without the autopilot {summaries['plant']['missed_commands']} "
              "time(s): this run is not deterministic", file=sys.stderr)  # fmt: skip
    return RunResult(scenario.name, controller, run_dir, metrics, run["sim_s"], wall_s)
