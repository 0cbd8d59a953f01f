"""The public API (tiltrotor_sitl) and its pytest plugin, as a user meets them: a user's own test folder outside
the repository run with `pytest -n 2`, bad input, and children that do not outlive their parent."""

from __future__ import annotations

import importlib.metadata
import math
import os
import tomllib
from pathlib import Path

import pytest

import tiltrotor_sitl
from tiltrotor_sitl import Faults, Fleet, ProcessOptions, Vehicle, VehicleError, Wind
from tiltrotor_sitl._launch import Options
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
    ({"speed": -1.0}, "speed must be a factor >= 0"),
    ({"speed": math.inf}, "speed must be a factor >= 0"),
    ({"spawn_alt": -1.0}, "spawn_alt must be"),
    ({"params": {"NO_SUCH": 1}}, "unknown parameter 'NO_SUCH'"),
    ({"params": {"MIS_TAKEOFF_ALT": 1e9}}, "MIS_TAKEOFF_ALT"),
    ({"instance": 5000}, "instance must be in 0..999"),
    ({"airframe": "/nonexistent.toml"}, "airframe: no such file"),
    ({"link_faults": 0.5}, "link_faults must be a Faults"),
    ({"processes": ProcessOptions(duration_s=0.0)}, "duration_s must be a positive number"),
    ({"processes": ProcessOptions(autopilot=False, plant_port=4560)}, "plant_port starts the autopilot alone .* not both"),
    ({"processes": ProcessOptions(plant_port=4560, plant_args=["--wind", "0,1,0"])},
     "plant_args with plant_port: no plant is started"),
    ({"processes": ProcessOptions(autopilot=False, autopilot_args=["--quiet"])}, "autopilot_args with autopilot=False"),
    ({"processes": ProcessOptions(autopilot_args="--quiet")}, "autopilot_args must be a sequence of strings"),
    ({"processes": ProcessOptions(plant_port=70000)}, "plant_port must be a UDP port"),
    ({"processes": ProcessOptions(autopilot=False), "link_faults": Faults(loss=0.1)}, "link_faults with autopilot=False"),
    ({"wind": Wind(from_north=99.0)}, "wind: SIH_WIND_N: 99 outside -40..40"),
    ({"wind": (3.0, 0.0)}, "wind must be a tiltrotor_sitl.Wind"),
    ({"wind": Wind(turbulence=1.0), "processes": ProcessOptions(plant_port=4560)}, "wind with plant_port"),
    ({"params": {"SIH_WIND_N": 3.0}}, "SIH_WIND_N is the plant's .*wind=Wind"),
])  # fmt: skip
def test_bad_arguments_are_named(arguments: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        Vehicle(**arguments)
    assert children_of(os.getpid()) == []


def test_an_expert_argument_given_flat_says_where_it_goes() -> None:
    with pytest.raises(TypeError, match=r"'summary' \(an expert argument: processes=ProcessOptions\(summary=...\)\)"):
        Vehicle(summary=True)  # type: ignore[call-arg]
    with pytest.raises(TypeError, match="processes must be a ProcessOptions, not dict"):
        Vehicle(processes={"summary": True})  # type: ignore[typeddict-item]


def test_speed_0_is_lockstep_as_none_is() -> None:
    assert Options.of({"speed": 0}).speed is None
    assert Options.of({"speed": 0.0}).speed is None
    assert Options.of({"speed": None}).speed is None
    assert Options.of({"speed": 2.0}).speed == 2.0


def test_a_vehicle_or_fleet_used_before_start_says_so() -> None:
    vehicle, fleet = Vehicle(), Fleet(2)
    for read in (lambda: vehicle.sysid, lambda: vehicle.pymavlink, lambda: vehicle.truth, lambda: vehicle.pids,
                 lambda: vehicle.ground_station, lambda: fleet[0], lambda: list(fleet), lambda: fleet.pymavlink,
                 lambda: fleet.folder):  # fmt: skip
        with pytest.raises(VehicleError, match="not started: use `with Vehicle"):
            read()
    assert len(fleet) == 2


def test_the_package_says_its_version_and_ships_its_types() -> None:
    assert tiltrotor_sitl.__version__ == importlib.metadata.version("tiltrotor-sitl")
    assert (Path(tiltrotor_sitl.__file__).parent / "py.typed").is_file()
    project = tomllib.loads((Path(__file__).parents[2] / "pyproject.toml").read_text())
    assert "py.typed" in project["tool"]["setuptools"]["package-data"]["tiltrotor_sitl"]


def test_instances_are_a_px4_fleet() -> None:
    assert [Ports(i).system_id for i in (0, 1, 2, 249, 250)] == [1, 2, 3, 250, 1]
    assert {Ports(i).gcs_remote for i in (0, 1, 7)} == {14550}
    assert (Ports(3).api_remote, Ports(3).api_bind) == (14543, 14583)


def test_the_worked_example_of_testing_md_is_the_example_file_the_suite_runs() -> None:
    """docs/testing.md shows docs/examples/test_takeoff_and_land.py (tests/sitl/test_api.py runs it), under 15 lines
    of code."""
    docs = Path(__file__).parents[2] / "docs"
    example = (docs / "examples" / "test_takeoff_and_land.py").read_text()
    code = example.split('"""', 2)[2].strip()
    shown = (docs / "testing.md").read_text().split("```python\n", 1)[1].split("```", 1)[0].strip()
    assert shown == code
    assert len([line for line in code.splitlines() if line.strip()]) < 15
