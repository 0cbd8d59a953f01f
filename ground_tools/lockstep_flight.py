"""Start `vtol-sim` and `vtol-autopilot` together in lockstep on a free port, fly a profile, collect the results.

Used by `vtol fly` and the SITL benchmark, so both run the processes one way (tests fly profiles through the public
API instead: tests/sitl.py).
"""

from __future__ import annotations

import select
import signal
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from tiltrotor_sitl._children import Child, Stream, start, stop
from tiltrotor_sitl._commands import AutopilotCommand, Controller, SimCommand, Zenoh, free_link_ports
from tiltrotor_sitl._free_ports import free_udp_port
from transport.mavlink import Link
from transport.ports import LOOPBACK

PROGRESS_PERIOD_S = 0.25  # wall seconds between progress reports
TIMED = ("ATTITUDE", "ATTITUDE_QUATERNION", "LOCAL_POSITION_NED", "GLOBAL_POSITION_INT", "SYSTEM_TIME")


class FlightFailed(RuntimeError):
    """A process of the flight exited with an error."""


@dataclass
class LockstepFlight:
    """Both processes' --summary of one flight."""

    autopilot: dict
    plant: dict


def _start(name: str, argv: list[str]) -> Child:
    """A process of the flight, deterministic, its stdout and stderr captured."""
    return start(name, argv, stdout=Stream.CAPTURE, stderr=Stream.CAPTURE, deterministic=True)


class TelemetryClock:
    """The autopilot's clock (simulated seconds), read from the telemetry its GCS link sends to 127.0.0.1:`port`
    while no ground station speaks: a listener that never speaks, so the vehicle sends on as before."""

    def __init__(self, port: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.bind((LOOPBACK, port))
        except OSError:
            self.sock.close()
            raise
        self.link = Link(255, 190)
        self.sim_s = 0.0

    def read(self, timeout_s: float) -> float:
        """What has arrived within `timeout_s` (wall): the latest time_boot_ms, in seconds."""
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            readable, _, _ = select.select([self.sock], [], [], left)
            if not readable:
                break
            for message in self.link.parse(self.sock.recv(65536)):
                if message.get_type() in TIMED:
                    self.sim_s = max(self.sim_s, message.time_boot_ms / 1000.0)
        return self.sim_s

    def close(self) -> None:
        self.sock.close()


def fly_lockstep(
    profile: str,
    duration_s: float,
    *,
    controller: Controller = "mpc",
    spawn_alt: float = 100.0,
    log_path: Path | None = None,
    autopilot_args: tuple[str, ...] = (),
    timeout_s: float = 900.0,
    autopilot_profile: Path | None = None,
    on_progress: Callable[[float], None] | None = None,
) -> LockstepFlight:
    """Fly `profile` for `duration_s` simulated seconds from a hover at `spawn_alt`; raises FlightFailed.
    autopilot_profile: run the autopilot under cProfile, its statistics written there (benchmarks). on_progress:
    told the simulated seconds flown, a few times a wall second (read from the vehicle's telemetry)."""
    port = free_udp_port()
    links = free_link_ports()
    clock = TelemetryClock(links.gcs_remote) if on_progress is not None else None
    plant = _start("vtol-sim", SimCommand(port=port, spawn_alt=spawn_alt, zenoh=Zenoh.off(), duration_s=duration_s,
                                          summary=True).argv())  # fmt: skip
    children = [plant]
    try:
        autopilot_command = AutopilotCommand(
            sim_port=port, links=links, spawn_alt=spawn_alt, profile=profile, duration_s=duration_s,
            controller=controller, summary=True, zenoh=Zenoh.off(), quiet=True, log=log_path, extra=autopilot_args,
        )  # fmt: skip
        argv = autopilot_command.argv()
        if (
            autopilot_profile is not None
        ):  # [python, -m, module, ...] -> [python, -m, cProfile, -o, FILE, -m, module, ...]
            argv = [argv[0], "-m", "cProfile", "-o", str(autopilot_profile), *argv[1:]]
        autopilot = _start("vtol-autopilot", argv)
        children.append(autopilot)
        deadline = time.monotonic() + timeout_s
        while autopilot.running():
            if time.monotonic() > deadline:
                raise FlightFailed(f"vtol-autopilot still flying after {timeout_s:g} wall seconds")
            if clock is None or on_progress is None:
                time.sleep(PROGRESS_PERIOD_S)
            else:
                on_progress(clock.read(PROGRESS_PERIOD_S))
        plant.wait(120)
    finally:
        stop(children, signal.SIGKILL)  # whatever still runs (a time-out, an interruption)
        if clock is not None:
            clock.close()
    if autopilot.returncode != 0:
        raise FlightFailed(f"vtol-autopilot exited with {autopilot.returncode}: {autopilot.stderr_text().strip()}")
    if plant.returncode != 0:
        raise FlightFailed(f"vtol-sim exited with {plant.returncode}: {plant.stderr_text().strip()}")
    return LockstepFlight(autopilot=autopilot.summary(), plant=plant.summary())
