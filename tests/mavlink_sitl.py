"""Plant + autopilot processes for the MAVLink tests, on free ports, with a pymavlink ground station on the GCS
link; every process is killed by its PID at the end."""

from __future__ import annotations

import json
import os
import signal
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

from ground_tools.processes import AutopilotCommand, LinkPorts, SimCommand, Zenoh, free_udp_port
from tests.ground_station import GroundStation


@dataclass
class Sitl:
    plant: subprocess.Popen
    autopilot: subprocess.Popen
    ports: dict[str, int]
    params_path: Path
    gs: GroundStation | None = None
    outputs: dict[str, tuple[str, str]] = field(default_factory=dict)

    def autopilot_command(self, *extra: str) -> list[str]:
        return autopilot_command(self.ports, self.params_path, *extra)

    def stop(self) -> tuple[dict, dict]:
        """SIGTERM both; their --summary lines (autopilot, plant)."""
        summaries = []
        for name, process in (("autopilot", self.autopilot), ("plant", self.plant)):
            if process.poll() is None:
                process.send_signal(signal.SIGTERM)
            out, _ = process.communicate(timeout=30)
            self.outputs[name] = (out, self.stderr(name))
            lines = [line for line in out.splitlines() if line.startswith("{")]
            summaries.append(json.loads(lines[-1]) if lines else {})
        return summaries[0], summaries[1]

    def stderr(self, name: str = "autopilot") -> str:
        return (self.params_path.parent / f"{name}.stderr").read_text()

    def kill(self) -> None:
        for process in (self.autopilot, self.plant):
            if process.poll() is None:
                process.kill()
            process.wait(timeout=30)
        if self.gs is not None:
            self.gs.close()


def autopilot_command(ports: dict[str, int], params_path: Path, *extra: str, spawn_alt: float = 0.0) -> list[str]:
    links = LinkPorts(ports["gcs"], ports["gcs_remote"], ports["api"], ports["api_remote"])
    return AutopilotCommand(sim_port=ports["sim"], links=links, spawn_alt=spawn_alt, params=params_path,
                            zenoh=Zenoh.off(), summary=True, extra=extra).argv()  # fmt: skip


def start_sitl(params_path: Path, *, spawn_alt: float = 0.0, speed: float | None = 4.0, autopilot_args=(),
               ground_station: bool = True) -> Sitl:  # fmt: skip
    """speed: real time times `speed` (None: lockstep). The ground station listens where the GCS link sends."""
    ports = {name: free_udp_port() for name in ("sim", "gcs", "gcs_remote", "api", "api_remote")}
    gs = GroundStation(ports["gcs_remote"]) if ground_station else None
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    with open(params_path.parent / "plant.stderr", "w") as errors:
        plant = subprocess.Popen(
            SimCommand(port=ports["sim"], spawn_alt=spawn_alt, realtime_speed=speed, zenoh=Zenoh.off(),
                       summary=True).argv(),
            stdout=subprocess.PIPE, stderr=errors, text=True, env=env,
        )  # fmt: skip
    with open(params_path.parent / "autopilot.stderr", "w") as errors:
        autopilot = subprocess.Popen(autopilot_command(ports, params_path, *autopilot_args, spawn_alt=spawn_alt),
                                     stdout=subprocess.PIPE, stderr=errors, text=True, env=env)  # fmt: skip
    return Sitl(plant, autopilot, ports, params_path, gs)
