"""Start `vtol-sim` and `vtol-autopilot` together in lockstep on a free port, fly a profile, collect the results.

Used by `vtol fly` and the SITL benchmark, so both run the processes one way (tests fly profiles through the public
API instead: tests/sitl.py).
"""

from __future__ import annotations

import signal
from dataclasses import dataclass
from pathlib import Path

from tiltrotor_sitl._children import Child, Stream, start, stop
from tiltrotor_sitl._commands import AutopilotCommand, Controller, SimCommand, Zenoh, free_link_ports
from tiltrotor_sitl._free_ports import free_udp_port


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


def fly_lockstep(
    profile: str,
    duration_s: float,
    *,
    controller: Controller = "pid",
    spawn_alt: float = 100.0,
    log_path: Path | None = None,
    autopilot_args: tuple[str, ...] = (),
    timeout_s: float = 900.0,
    autopilot_profile: Path | None = None,
) -> LockstepFlight:
    """Fly `profile` for `duration_s` simulated seconds from a hover at `spawn_alt`; raises FlightFailed.
    autopilot_profile: run the autopilot under cProfile, its statistics written there (benchmarks)."""
    port = free_udp_port()
    plant = _start("vtol-sim", SimCommand(port=port, spawn_alt=spawn_alt, zenoh=Zenoh.off(), duration_s=duration_s,
                                          summary=True).argv())  # fmt: skip
    children = [plant]
    try:
        autopilot_command = AutopilotCommand(
            sim_port=port, links=free_link_ports(), spawn_alt=spawn_alt, profile=profile, duration_s=duration_s,
            controller=controller, summary=True, zenoh=Zenoh.off(), quiet=True, log=log_path, extra=autopilot_args,
        )  # fmt: skip
        argv = autopilot_command.argv()
        if (
            autopilot_profile is not None
        ):  # [python, -m, module, ...] -> [python, -m, cProfile, -o, FILE, -m, module, ...]
            argv = [argv[0], "-m", "cProfile", "-o", str(autopilot_profile), *argv[1:]]
        autopilot = _start("vtol-autopilot", argv)
        children.append(autopilot)
        autopilot.wait(timeout_s)
        plant.wait(120)
    finally:
        stop(children, signal.SIGKILL)  # whatever still runs (a time-out, an interruption)
    if autopilot.returncode != 0:
        raise FlightFailed(f"vtol-autopilot exited with {autopilot.returncode}: {autopilot.stderr_text().strip()}")
    if plant.returncode != 0:
        raise FlightFailed(f"vtol-sim exited with {plant.returncode}: {plant.stderr_text().strip()}")
    return LockstepFlight(autopilot=autopilot.summary(), plant=plant.summary())
