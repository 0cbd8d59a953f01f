"""MAVSDK-Python 4 as the tests use it: a ground station connected to a vehicle's API link, its autopilot found.
Import it after `pytest.importorskip("mavsdk", minversion="4")` (MAVSDK is a test extra)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from mavsdk import ComponentType, Configuration, Mavsdk

AUTOPILOT_TIMEOUT_S = 60.0


def connect_autopilot(url: str, timeout_s: float = AUTOPILOT_TIMEOUT_S) -> tuple[Mavsdk, Any]:
    """A MAVSDK ground station on `url` (e.g. "udpin://127.0.0.1:P", or `Vehicle.mavsdk`) and the autopilot it found
    (the caller destroys the Mavsdk); AssertionError when none answers within `timeout_s`."""
    drone = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    try:
        drone.add_any_connection(url)
        system = drone.first_autopilot(timeout_s)
        assert system is not None, "MAVSDK found no autopilot"
    except BaseException:
        drone.destroy()
        raise
    return drone, system


@contextmanager
def mavsdk_autopilot(url: str, timeout_s: float = AUTOPILOT_TIMEOUT_S) -> Iterator[Any]:
    """connect_autopilot() as a block: the autopilot's System, the Mavsdk destroyed when the block ends."""
    drone, system = connect_autopilot(url, timeout_s)
    try:
        yield system
    finally:
        drone.destroy()
