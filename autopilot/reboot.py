"""The autopilot's reboot (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN param1 1, docs/mavlink.md#reboot): once everything is
closed and written, the process executes itself again, so it keeps its PID (every launcher, `vtol up`, Vehicle and
Fleet, goes on watching and stopping the same process), its parent-death signal, its stdout and stderr.

The new process reads its parameters and missions again, as a PX4 flight controller does at boot. Its command line
is the old one, changed as a reboot must change it:
- the options whose parameter was set since the start give way to the parameter (--sysid to MAV_SYS_ID,
  --controller to VT_CTRL, --mpc-horizon to VT_MPC_HRZN);
- what only a first start does is left out (--spawn-alt: a rebooted vehicle stands disarmed where it is;
  --profile and --failure: a scripted flight's, timed from the first start);
- the plant link binds the port it had (--sim-bind-port), so the plant, which belongs to that address, takes the
  new process at once (docs/plant-link.md, "The handshake").
"""

from __future__ import annotations

import os
import re
import sys
from collections.abc import Iterable, Sequence

OVERRIDDEN_BY = {"MAV_SYS_ID": "--sysid", "VT_CTRL": "--controller", "VT_MPC_HRZN": "--mpc-horizon"}
FIRST_START_ONLY = ("--spawn-alt", "--profile", "--failure")
PLANT_BIND = "--sim-bind-port"
SAID_SYSID = re.compile(r"^vtol-autopilot: .*?\bsystem id (\d+),", re.MULTILINE)  # in the start line on stderr


def said_sysid(system_id: int) -> str:
    """How the autopilot's start line on stderr names its system id (launchers read it after a reboot)."""
    return f"system id {system_id}"


def started_sysid(stderr: str) -> int | None:
    """The system id the autopilot said it started with last in `stderr`, None if it said none."""
    found = SAID_SYSID.findall(stderr)
    return int(found[-1]) if found else None


def without_options(argv: Sequence[str], names: Iterable[str]) -> list[str]:
    """`argv` without the options `names`, each given as "--name VALUE" or "--name=VALUE" (each takes a value)."""
    names = tuple(names)
    kept: list[str] = []
    skip_value = False
    for word in argv:
        if skip_value:
            skip_value = False
        elif word in names:
            skip_value = True
        elif not word.startswith(tuple(f"{name}=" for name in names)):
            kept.append(word)
    return kept


def reboot_argv(argv: Sequence[str], parameters_set: Iterable[str], plant_port: int) -> list[str]:
    """The command line (arguments after the program) of the process after a reboot: `parameters_set` are the
    parameters set since the start, `plant_port` the plant link's local port."""
    overridden = [OVERRIDDEN_BY[name] for name in parameters_set if name in OVERRIDDEN_BY]
    kept = without_options(argv, [*overridden, *FIRST_START_ONLY, PLANT_BIND])
    return [*kept, PLANT_BIND, str(plant_port)]


def execute_again(arguments: Sequence[str]) -> None:
    """Replace this process by `python -m autopilot arguments` (never returns; OSError if it cannot)."""
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(sys.executable, [sys.executable, "-m", "autopilot", *arguments])
