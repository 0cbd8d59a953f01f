"""Start `vtol-sim` and `vtol-autopilot` together in lockstep on a free port, fly a profile, collect the results.

Used by `vtol fly`, the SITL benchmark and the closed-loop tests, so all three run the processes one way.
"""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path


class FlightFailed(RuntimeError):
    """A process of the flight exited with an error."""


@dataclass
class LockstepFlight:
    """Both processes' --summary of one flight."""

    autopilot: dict
    plant: dict


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def free_tcp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def free_link_ports() -> tuple[str, ...]:
    """vtol-autopilot options putting its ground-station links on free ports (nobody listens on the remote
    ones), so an autopilot can run beside a `vtol up` or another one."""
    return ("--gcs-port", str(free_udp_port()), "--gcs-remote-port", str(free_udp_port()),
            "--api-port", str(free_udp_port()), "--api-remote-port", str(free_udp_port()))  # fmt: skip


def fly_lockstep(
    profile: str,
    duration_s: float,
    *,
    controller: str = "pid",
    spawn_alt: float = 100.0,
    log_path: Path | None = None,
    autopilot_args: tuple[str, ...] = (),
    timeout_s: float = 900.0,
) -> LockstepFlight:
    """Fly `profile` for `duration_s` simulated seconds from a hover at `spawn_alt`; raises FlightFailed."""
    port = str(free_udp_port())
    link_ports = free_link_ports()
    plant = subprocess.Popen(
        [sys.executable, "-m", "sim_bridge", "--port", port, "--spawn-alt", str(spawn_alt), "--no-zenoh",
         "--duration", str(duration_s), "--summary"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    log_args = ("--log", str(log_path)) if log_path is not None else ()
    try:
        autopilot = subprocess.run(
            [sys.executable, "-m", "autopilot", "--sim-port", port, "--spawn-alt", str(spawn_alt),
             "--profile", profile, "--duration", str(duration_s), "--controller", controller, "--summary",
             "--no-zenoh", "--quiet", *link_ports, *log_args, *autopilot_args],
            capture_output=True, text=True, timeout=timeout_s,
        )  # fmt: skip
        plant_out, plant_err = plant.communicate(timeout=120)
    finally:
        if plant.poll() is None:
            plant.kill()
            plant.wait()
    if autopilot.returncode != 0:
        raise FlightFailed(f"vtol-autopilot exited with {autopilot.returncode}: {autopilot.stderr.strip()}")
    if plant.returncode != 0:
        raise FlightFailed(f"vtol-sim exited with {plant.returncode}: {plant_err.strip()}")
    return LockstepFlight(
        autopilot=json.loads(autopilot.stdout.strip().splitlines()[-1]),
        plant=json.loads(plant_out.strip().splitlines()[-1]),
    )
