"""The pytest plugin (entry point pytest11, installed with the package): vehicles for a user's tests.

Fixtures:
    vehicle          one Vehicle, ready to arm, stopped after the test (controller and speed from the options)
    vehicle_factory  vehicle_factory(**Vehicle arguments) -> a started Vehicle; all are stopped after the test
    fleet_factory    fleet_factory(count, **Fleet arguments) -> a started Fleet; all are stopped after the test

Options: --vtol-controller mpc|pid (default mpc), --vtol-speed F (default 1; 0 = lockstep as fast as possible).

Safe under pytest-xdist: every vehicle is on free ports unless a test asks for an instance, so workers share
nothing.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from tiltrotor_sitl import Controller, Fleet, Vehicle


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


def _defaults(config: pytest.Config) -> dict[str, Any]:
    controller: Controller = "pid" if config.getoption("--vtol-controller") == "pid" else "mpc"
    speed: float = config.getoption("--vtol-speed")
    return {"controller": controller, "speed": speed if speed > 0 else None}


@pytest.fixture
def vehicle_factory(request: pytest.FixtureRequest) -> Iterator[Callable[..., Vehicle]]:
    """vehicle_factory(**arguments of Vehicle) -> a started Vehicle (options' controller and speed by default)."""
    started: list[Vehicle] = []

    def start(**arguments: Any) -> Vehicle:
        vehicle = Vehicle(**{**_defaults(request.config), **arguments})
        vehicle.start()
        started.append(vehicle)
        return vehicle

    try:
        yield start
    finally:
        for vehicle in reversed(started):
            vehicle.stop()


@pytest.fixture
def vehicle(vehicle_factory: Callable[..., Vehicle]) -> Vehicle:
    """One vehicle on free ports, on the ground, ready to arm."""
    return vehicle_factory()


@pytest.fixture
def fleet_factory(request: pytest.FixtureRequest) -> Iterator[Callable[..., Fleet]]:
    """fleet_factory(count, **arguments of Fleet) -> a started Fleet (options' controller and speed by default)."""
    started: list[Fleet] = []

    def start(count: int, **arguments: Any) -> Fleet:
        fleet = Fleet(count, **{**_defaults(request.config), **arguments})
        fleet.start()
        started.append(fleet)
        return fleet

    try:
        yield start
    finally:
        for fleet in reversed(started):
            fleet.stop()
