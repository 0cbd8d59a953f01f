"""The MAVLink tests' vehicle: a thin layer over the public API (tiltrotor_sitl.Vehicle), with its files in the
test's folder, its --summary counters, and a pymavlink ground station on the GCS link."""

from __future__ import annotations

import subprocess
from dataclasses import dataclass
from pathlib import Path

from tests.sitl.ground_station import GroundStation
from tiltrotor_sitl import Controller, ProcessOptions, Vehicle


@dataclass
class Sitl:
    vehicle: Vehicle
    gs: GroundStation | None = None

    @property
    def ports(self) -> dict[str, int]:
        ports = self.vehicle.ports
        return {"sim": ports.plant, "gcs": ports.links.gcs_bind, "gcs_remote": ports.links.gcs_remote,
                "api": ports.links.api_bind, "api_remote": ports.links.api_remote}  # fmt: skip

    @property
    def params_path(self) -> Path:
        return self.vehicle.params_path

    @property
    def autopilot(self) -> subprocess.Popen:
        return self.vehicle.process("vtol-autopilot")

    @property
    def plant(self) -> subprocess.Popen:
        return self.vehicle.process("vtol-sim")

    def restart_autopilot(self) -> None:
        """A new autopilot on the same command line, ports and files."""
        self.vehicle.restart("vtol-autopilot")

    def stop(self) -> tuple[dict, dict]:
        """Stop both (SIGTERM, the autopilot first); their --summary counters (autopilot, plant)."""
        self.vehicle.stop()
        return self.vehicle.summary("vtol-autopilot"), self.vehicle.summary("vtol-sim")

    def stderr(self, name: str = "autopilot") -> str:
        return self.vehicle.stderr(f"vtol-{'sim' if name == 'plant' else name}")

    def kill(self) -> None:
        self.vehicle.stop()
        if self.gs is not None:
            self.gs.close()


def start_sitl(params_path: Path, *, spawn_alt: float = 0.0, speed: float | None = 4.0, controller: Controller = "mpc",
               autopilot_args: tuple[str, ...] = (), ground_station: bool = True, wait_ready: bool = True) -> Sitl:  # fmt: skip
    """A vehicle ready to arm, keeping `params_path` (its files beside it). speed: real time times `speed` (None:
    lockstep). The ground station listens where the GCS link sends."""
    vehicle = Vehicle(
        controller=controller,
        spawn_alt=spawn_alt,
        speed=speed,
        truth=False,
        folder=params_path.parent,
        processes=ProcessOptions(
            summary=True, params_file=params_path, autopilot_args=autopilot_args, wait_ready=wait_ready
        ),
    ).start()
    try:
        gs = GroundStation(vehicle.gcs_port, vehicle.sysid) if ground_station else None
    except BaseException:
        vehicle.stop()
        raise
    return Sitl(vehicle, gs)
