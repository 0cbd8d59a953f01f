"""The plant alone (started through the public API), for the tests that play its autopilot."""

from __future__ import annotations

import subprocess
import time
from collections.abc import Iterator
from dataclasses import dataclass

import pytest

from tiltrotor_sitl import ProcessOptions, Vehicle
from transport.plant_link import PlantLinkClient, PlantSample


@dataclass
class PlantProcess:
    """A plant alone (`vtol-sim` started through tiltrotor_sitl.Vehicle(autopilot=False)) and a plant-link client
    talking to it: the test plays the autopilot."""

    vehicle: Vehicle
    client: PlantLinkClient

    @property
    def process(self) -> subprocess.Popen:
        return self.vehicle.process("vtol-sim")

    @property
    def port(self) -> int:
        return self.vehicle.ports.plant

    @property
    def zenoh_endpoint(self) -> str:
        return self.vehicle.ports.zenoh_plant

    def first_sample(self, timeout_s: float = 60.0) -> PlantSample:
        """Say hello until the plant answers with its first state (it starts stepping on our first message)."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise AssertionError(f"vtol-sim exited early: {self.vehicle.stderr('vtol-sim')}")
            self.client.hello()
            sample = self.client.receive_step(0.2)
            if sample is not None:
                return sample
        raise AssertionError("vtol-sim did not start within the timeout")

    def stop(self) -> dict:
        """SIGTERM the plant, return its --summary counters."""
        self.vehicle.stop()
        return self.vehicle.summary("vtol-sim")


@pytest.fixture
def start_plant(tmp_path) -> Iterator:
    """Factory: start_plant(*vtol-sim args, zenoh=False) -> PlantProcess: the plant alone on free ports, in
    lockstep unless the args say otherwise, with --summary; zenoh (truth) only when asked."""
    started: list[PlantProcess] = []

    def start(*args: str, zenoh: bool = False) -> PlantProcess:
        vehicle = Vehicle(
            speed=None,
            truth=zenoh,
            folder=tmp_path / f"plant-{len(started)}",
            processes=ProcessOptions(autopilot=False, summary=True, plant_args=args),
        ).start()
        plant = PlantProcess(vehicle, PlantLinkClient(vehicle.ports.plant))
        started.append(plant)
        return plant

    yield start
    for plant in started:
        plant.client.close()
        plant.vehicle.stop()
