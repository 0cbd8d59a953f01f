"""When the plant loop builds the VehicleStatus snapshot for the MAVLink services (autopilot/plant_loop.py, step 4;
docs/architecture.md): at every step with news for the services, at least every 10 ms, and not at the steps in
between; the telemetry streams' own steps are covered through MAVLink by tests/test_scenarios.py."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from aircraft.airframe import load_airframe
from aircraft.failures import FailureType, FailureUnit, parse_failure
from autopilot.commander.commander import build_commander
from autopilot.commander.failure_injection import FailureInjection
from autopilot.controllers import build_flight_controller
from autopilot.plant_loop import STATUS_MAX_AGE_USEC, PlantLoop
from autopilot.storage.mission_store import MissionStore
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.controller_kind import PID
from autopilot.topics.vehicle_status import EventOutbox
from transport.geodesy import Home
from transport.mavlink import mavlink
from transport.plant_link import PlantLinkClient, PlantSample

STEP_USEC = 2500


@pytest.fixture
def loop(tmp_path):
    airframe = load_airframe()
    params = ParameterStore(tmp_path / "params.json")
    missions = MissionStore(tmp_path / "missions.json")
    events = EventOutbox()
    commander = build_commander(params, 0.5, armed=True, in_air=True, say=events.say, missions=missions, home=Home())
    client = PlantLinkClient(9, sensors=False)  # never used: the test calls the loop's status steps itself
    injection = FailureInjection(send=lambda failure: True, note=lambda text: None)
    loop = PlantLoop(airframe, lambda: build_flight_controller(airframe, PID), client, commander, params, injection,
                     events, services=None, home=Home(), missions=missions)  # fmt: skip
    yield loop
    client.close()


def published(loop: PlantLoop, t_usec: int) -> bool:
    """Step 4 at t_usec: True if the loop built a snapshot (and handed it on)."""
    if not loop._status_due(t_usec):
        return False
    state = SimpleNamespace(lat=0, lon=0, alt=0, vx=0, vy=0, vz=0)
    loop._status(t_usec, PlantSample(t_usec, state), [1500] * 12)
    return True


def test_a_snapshot_at_each_step_with_news_and_every_10_ms_in_between(loop):
    t = 0
    assert published(loop, t)  # the first one
    quiet = [published(loop, t := t + STEP_USEC) for _ in range(3)]
    assert quiet == [False, False, False]
    assert published(loop, t := t + STEP_USEC) and t == STATUS_MAX_AGE_USEC  # 10 ms since the last
    assert not published(loop, t := t + STEP_USEC)

    loop.events.say(mavlink.MAV_SEVERITY_INFO, "an event")  # news: at the step it is said, drained once
    assert published(loop, t := t + STEP_USEC) and not published(loop, t := t + STEP_USEC)

    loop.injection.request(parse_failure(FailureUnit.MOTOR, FailureType.OFF, 1, 0.0), t, ticket=7)
    loop.injection.acknowledged(mavlink.MAV_RESULT_ACCEPTED, t, 0.0)  # an answer for the ground station
    assert published(loop, t := t + STEP_USEC) and not published(loop, t := t + STEP_USEC)

    state = loop.state
    assert loop.commander.disarm(state, force=True)[0] == mavlink.MAV_RESULT_ACCEPTED  # arming state: a HEARTBEAT
    assert published(loop, t := t + STEP_USEC) and not published(loop, t := t + STEP_USEC)

    loop.missions.clear(mavlink.MAV_MISSION_TYPE_FENCE)  # a new mission store snapshot
    assert published(loop, t := t + STEP_USEC) and not published(loop, t := t + STEP_USEC)

    loop.commander.homes.set_here(np.array([5.0, 0.0, 0.0]))  # a new home
    assert published(loop, t := t + STEP_USEC) and not published(loop, t := t + STEP_USEC)

    assert published(loop, 0)  # the clock went back (a new plant run)
    assert loop.counters.status_snapshots == 8
