"""The public API (tiltrotor_sitl) and its pytest plugin, as a user meets them: a user's own test folder outside
the repository run with `pytest -n 2`, bad input, and children that do not outlive their parent."""

from __future__ import annotations

import os

import pytest

from tiltrotor_sitl import Vehicle
from transport.ports import Ports


def children_of(pid: int) -> list[int]:
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as stat:
                    fields = stat.read().rsplit(") ", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid and fields[0] != "Z":
                found.append(int(entry))
    return found


@pytest.mark.parametrize("arguments, message", [
    ({"controller": "lqr"}, "controller must be 'mpc' or 'pid'"),
    ({"speed": 0.0}, "speed must be a positive factor"),
    ({"spawn_alt": -1.0}, "spawn_alt must be"),
    ({"params": {"NO_SUCH": 1}}, "unknown parameter 'NO_SUCH'"),
    ({"params": {"MIS_TAKEOFF_ALT": 1e9}}, "MIS_TAKEOFF_ALT"),
    ({"instance": 5000}, "instance must be in 0..999"),
    ({"airframe": "/nonexistent.toml"}, "airframe: no such file"),
    ({"duration_s": 0.0}, "duration_s must be a positive number"),
    ({"autopilot": False, "plant_port": 4560}, "plant_port starts the autopilot alone .* not both"),
    ({"plant_port": 4560, "plant_args": ["--wind", "0,1,0"]}, "plant_args with plant_port: no plant is started"),
    ({"autopilot": False, "autopilot_args": ["--quiet"]}, "autopilot_args with autopilot=False"),
    ({"plant_port": 70000}, "plant_port must be a UDP port"),
])  # fmt: skip
def test_bad_arguments_are_named(arguments: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        Vehicle(**arguments)
    assert children_of(os.getpid()) == []


def test_instances_are_a_px4_fleet() -> None:
    assert [Ports(i).system_id for i in (0, 1, 2, 249, 250)] == [1, 2, 3, 250, 1]
    assert {Ports(i).gcs_remote for i in (0, 1, 7)} == {14550}
    assert (Ports(3).api_remote, Ports(3).api_bind) == (14543, 14583)
