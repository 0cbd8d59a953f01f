"""The pytest plugin (entry point pytest11, installed with the package): vehicles for a user's tests.

Fixtures:
    vehicle          one Vehicle, ready to arm, stopped after the test (controller and speed from the options)
    vehicle_factory  vehicle_factory(**Vehicle arguments) -> a started Vehicle; all are stopped after the test
    fleet_factory    fleet_factory(count, **Fleet arguments) -> a started Fleet; all are stopped after the test

Options: --vtol-controller mpc|pid (default mpc), --vtol-speed F (default 1; 0 = lockstep as fast as possible),
--vtol-keep-logs (keep the vehicles' folders of passing tests too).

Each vehicle's folder (its parameter file, the processes' stdout and stderr, its ULogs, the ground station's .tlog)
is under the test's tmp_path, in vtol-<n>/ (the n-th Vehicle or Fleet the test started). When a test fails, its
report gets a section per vehicle: the folder and its files, its ULogs, the vehicle's last status (mode, armed, failsafe), its last truth
sample, and the last lines of both processes' stderr; the folder is kept. A passing test's folders are removed
unless --vtol-keep-logs.

Safe under pytest-xdist: every vehicle is on free ports unless a test asks for an instance, so workers share
nothing.
"""

from __future__ import annotations

import argparse
import shutil
from collections.abc import Callable, Generator, Iterator
from pathlib import Path
from typing import Any

import pytest

from tiltrotor_sitl import Fleet, Vehicle, VehicleHandle
from tiltrotor_sitl._report import vehicle_report

_STARTED = pytest.StashKey[list[Vehicle | Fleet]]()  # what the test's fixtures started, in order
_FAILED = pytest.StashKey[bool]()
_FOLDERS = pytest.StashKey[int]()  # vtol-<n> folders handed out in the test


def _speed(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not value >= 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be >= 0 (0: lockstep as fast as possible): {text!r}")
    return value


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("tiltrotor-sitl", "tiltrotor-sitl vehicles")
    group.addoption("--vtol-controller", choices=("mpc", "pid"), default="mpc",
                    help="velocity controller of the vehicles the fixtures start (default mpc)")  # fmt: skip
    group.addoption("--vtol-speed", type=_speed, default=1.0, metavar="F",
                    help="simulated seconds per wall second of the vehicles the fixtures start (default 1; "
                         "0: lockstep as fast as possible)")  # fmt: skip
    group.addoption("--vtol-keep-logs", action="store_true",
                    help="keep the vehicles' folders (parameter file, stderr, ULogs, .tlog) of passing tests too; a "
                         "failed test's are always kept")  # fmt: skip


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Generator[None, Any, Any]:
    """A failed test's report gets a section per vehicle its fixtures started (tiltrotor_sitl/_report.py)."""
    report = yield
    if report.failed:
        item.stash[_FAILED] = True
        for vehicle in _vehicles(item.stash.get(_STARTED, [])):
            report.sections.append((f"vtol vehicle {vehicle.sysid} ({report.when})", vehicle_report(vehicle)))
    return report


def _vehicles(started: list[Vehicle | Fleet]) -> Iterator[VehicleHandle]:
    for each in started:
        if isinstance(each, Fleet):
            yield from each.vehicles
        else:
            yield each


def _defaults(config: pytest.Config, folder: Path) -> dict[str, Any]:
    return {"controller": config.getoption("--vtol-controller"), "speed": config.getoption("--vtol-speed"),
            "folder": folder}  # fmt: skip


class _Started:
    """The Vehicles and Fleets a test's fixture started, their folders under the test's tmp_path, and their end."""

    def __init__(self, request: pytest.FixtureRequest, tmp_path: Path) -> None:
        self.request = request
        self.tmp_path = tmp_path
        self.folders: list[Path] = []
        self.mine: list[Vehicle | Fleet] = []
        self.started = request.node.stash.setdefault(_STARTED, [])

    def defaults(self) -> dict[str, Any]:
        """The options' controller and speed, and the next vtol-<n> folder under tmp_path."""
        stash = self.request.node.stash
        number = stash[_FOLDERS] = stash.get(_FOLDERS, -1) + 1
        folder = self.tmp_path / f"vtol-{number}"
        self.folders.append(folder)
        return _defaults(self.request.config, folder)

    def add(self, vehicle: Vehicle | Fleet) -> None:
        self.started.append(vehicle)
        self.mine.append(vehicle)

    def stop(self) -> None:
        for vehicle in reversed(self.mine):
            vehicle.stop()
        failed = self.request.node.stash.get(_FAILED, False)
        if not failed and not self.request.config.getoption("--vtol-keep-logs"):
            for folder in self.folders:
                shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture
def vehicle_factory(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Callable[..., Vehicle]]:
    """vehicle_factory(**arguments of Vehicle) -> a started Vehicle (options' controller and speed, and a folder
    under tmp_path, by default)."""
    started = _Started(request, tmp_path)

    def start(**arguments: Any) -> Vehicle:
        vehicle = Vehicle(**{**started.defaults(), **arguments}).start()
        started.add(vehicle)
        return vehicle

    try:
        yield start
    finally:
        started.stop()


@pytest.fixture
def vehicle(vehicle_factory: Callable[..., Vehicle]) -> Vehicle:
    """One vehicle on free ports, on the ground, ready to arm."""
    return vehicle_factory()


@pytest.fixture
def fleet_factory(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Callable[..., Fleet]]:
    """fleet_factory(count, **arguments of Fleet) -> a started Fleet (options' controller and speed, and a folder
    under tmp_path, by default)."""
    started = _Started(request, tmp_path)

    def start(count: int, **arguments: Any) -> Fleet:
        fleet = Fleet(count, **{**started.defaults(), **arguments}).start()
        started.add(fleet)
        return fleet

    try:
        yield start
    finally:
        started.stop()
