"""Shared fixtures: the airframe, free ports, and real plant processes that are always killed by PID."""

from __future__ import annotations

import json
import os
import signal
import subprocess
from collections.abc import Iterator
from dataclasses import dataclass, field

import pytest

from aircraft.airframe import Airframe, load_airframe
from ground_tools.processes import SimCommand, Zenoh, free_udp_port
from transport.plant_link import PlantLinkClient, PlantSample


@pytest.fixture(scope="session", autouse=True)
def isolated_parameter_files(tmp_path_factory) -> Iterator[None]:
    """Autopilots started by the tests keep their default parameter file in a temporary folder, not the user's."""
    previous = os.environ.get("XDG_STATE_HOME")
    os.environ["XDG_STATE_HOME"] = str(tmp_path_factory.mktemp("state"))
    yield
    if previous is None:
        os.environ.pop("XDG_STATE_HOME", None)
    else:
        os.environ["XDG_STATE_HOME"] = previous


@pytest.fixture(scope="session")
def airframe() -> Airframe:
    return load_airframe()


@dataclass
class PlantProcess:
    """A running `vtol-sim` and a plant-link client talking to it."""

    process: subprocess.Popen
    port: int
    client: PlantLinkClient
    output: str = ""
    errors: str = ""
    extra: dict = field(default_factory=dict)

    def first_sample(self, timeout_s: float = 60.0) -> PlantSample:
        """Say hello until the plant answers with its first state (it starts stepping on our first message)."""
        import time

        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise AssertionError(f"vtol-sim exited early: {self.process.communicate()[1]}")
            self.client.hello()
            sample = self.client.receive_step(0.2)
            if sample is not None:
                return sample
        raise AssertionError("vtol-sim did not start within the timeout")

    def stop(self) -> dict:
        """SIGTERM the plant, return its --summary counters."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
        self.output, self.errors = self.process.communicate(timeout=20)
        lines = [line for line in self.output.splitlines() if line.startswith("{")]
        return json.loads(lines[-1]) if lines else {}


def vtol_sim_command(*args: str) -> list[str]:
    """vtol-sim with exactly `args` (each test says what it wants)."""
    return SimCommand(extra=args).argv()


@pytest.fixture
def start_plant() -> Iterator:
    """Factory: start_plant(*args) -> PlantProcess on a free port with --no-zenoh --summary (unless zenoh asked)."""
    started: list[PlantProcess] = []

    def start(*args: str) -> PlantProcess:
        port = free_udp_port()
        zenoh = Zenoh() if any(a.startswith("--zenoh") for a in args) else Zenoh.off()
        process = subprocess.Popen(
            SimCommand(port=port, summary=True, zenoh=zenoh, extra=args).argv(), stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )  # fmt: skip
        plant = PlantProcess(process, port, PlantLinkClient(port))
        started.append(plant)
        return plant

    yield start
    for plant in started:
        plant.client.close()
        if plant.process.poll() is None:
            plant.process.kill()
        plant.process.wait(timeout=20)
