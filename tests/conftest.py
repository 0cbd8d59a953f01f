"""Shared fixtures: the airframe and isolated parameter files; tests under tests/sitl/ are marked `sitl`."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from aircraft.airframe import Airframe, load_airframe
from tiltrotor_sitl._commands import SimCommand


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


def vtol_sim_command(*args: str) -> list[str]:
    """vtol-sim with exactly `args` (each test says what it wants), for the tests of its command line."""
    return SimCommand(extra=args).argv()


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Every test under tests/sitl/ starts processes or opens sockets: marked `sitl` (`-m "not sitl"` leaves them)."""
    sitl = Path(__file__).parent / "sitl"
    for item in items:
        if sitl in Path(item.path).parents:
            item.add_marker(pytest.mark.sitl)
