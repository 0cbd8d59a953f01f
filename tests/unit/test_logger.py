"""The logger in one process, with the real commander and flight controller: when a log starts and ends
(SDLOG_MODE 0, 1, 2), the texts around the arming and the disarming, parameter changes, a new plant run, a log
that cannot be created; each log read back by pyulog."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import pytest

from aircraft.airframe import load_airframe
from autopilot.commander.commander import Commander, build_commander
from autopilot.commander.failure_injection import FailureInjection
from autopilot.control.flight_controller import FlightController
from autopilot.controllers import build_flight_controller
from autopilot.logger.logger import Logger, VehicleIdentity
from autopilot.storage.mission_store import MissionStore
from autopilot.storage.parameters import ParameterStore
from autopilot.storage.vehicle_files import VehicleFiles
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.vehicle_status import EventOutbox
from transport.geodesy import Home
from transport.mavlink import mavlink as M

pyulog = pytest.importorskip("pyulog", reason="pyulog is a test extra: pip install '.[test]'")
STEP = 2500
START_WALL = dt.datetime(2026, 5, 4, 10, 31, 2, tzinfo=dt.UTC).timestamp()


class Bench:
    """A commander on the ground, a PID flight controller, the logger, stepped by hand."""

    def __init__(self, root: Path, mode: int = 0) -> None:
        airframe = load_airframe(None)
        self.params = ParameterStore(None)
        self.params.set("SDLOG_MODE", mode)
        self.events = EventOutbox()
        home = Home(47.397742, 8.545594, 488.0)
        self.commander: Commander = build_commander(
            self.params, airframe.hover_thrust_per_rotor / airframe.thrust_max, armed=False, in_air=False,
            say=self.events.say, profile=None, stamped_setpoints=False, missions=MissionStore(), home=home)  # fmt: skip
        self.controller: FlightController = build_flight_controller(airframe, "pid", self.params)
        self.notes: list[str] = []
        self.files = VehicleFiles.at(root)
        identity = VehicleIdentity(1, home, self.commander.navigator.ids, airframe.gravity, 4 * airframe.thrust_max)
        self.logger = Logger(self.files, self.params, self.commander, MissionStore(), FailureInjection(
            send=lambda failure: None, note=self.notes.append, scheduled=[]), identity, note=self.notes.append,
            wall_clock=lambda: START_WALL)  # fmt: skip
        self.state = VehicleState(time_usec=1_000_000, valid=True)
        self.commander.observe(self.state)
        self.commander.start(self.state)

    def run(self, seconds: float) -> None:
        """Plant steps for `seconds`, each one's events said afterwards (as the MAVLink services say them)."""
        for _ in range(int(round(seconds * 1e6 / STEP))):
            self.state.time_usec += STEP
            self.commander.observe(self.state)
            self.logger.step(self.state.time_usec, self.state, self.controller, [1000] * 12)
            for event in self.events.drain():
                self.logger.statustext(self.state.time_usec, event.severity, event.text)

    def arm(self, armed: bool) -> None:
        reply = self.commander.arm(self.state) if armed else self.commander.disarm(self.state)
        assert reply[0] == M.MAV_RESULT_ACCEPTED
        for event in self.events.drain():
            self.logger.statustext(self.state.time_usec, event.severity, event.text)

    def logs(self) -> list:
        self.logger.close()
        return [pyulog.ULog(str(entry.path)) for entry in self.files.logs()]


def span_s(log) -> tuple[float, float]:
    return log.start_timestamp / 1e6, log.last_timestamp / 1e6


def test_mode_0_a_log_from_arming_to_disarming_with_their_texts(tmp_path):
    bench = Bench(tmp_path)
    bench.run(1.0)
    assert bench.logger.logging is None
    bench.arm(True)
    bench.run(2.0)
    bench.params.set("MPC_XY_P", 0.5)
    bench.run(1.0)
    bench.arm(False)
    bench.run(1.0)
    bench.arm(True)
    bench.run(0.5)
    first, second = bench.logs()
    assert span_s(first)[0] == pytest.approx(2.0025) and span_s(first)[1] == pytest.approx(5.0025, abs=0.01)
    assert [m.message for m in first.logged_messages] == ["Armed", "Disarmed"]
    assert [(name, value) for _, name, value in first.changed_parameters] == [("MPC_XY_P", 0.5)]
    assert first.initial_parameters["SDLOG_MODE"] == 0 and second.initial_parameters["MPC_XY_P"] == 0.5
    assert [e.path.name for e in bench.files.logs()] == ["10_31_03.ulg", "10_31_07.ulg"]  # the vehicle's clock
    vehicle_status = first.get_dataset("vehicle_status").data
    assert list(vehicle_status["arming_state"]) == [2] * (len(vehicle_status["arming_state"]) - 1) + [1]
    assert set(vehicle_status["nav_state"]) == {4}  # Hold


@pytest.mark.parametrize("mode, spans", [(1, [(1.0025, 3.0025), (4.0, 5.0)]), (2, [(1.0025, 5.0)])])
def test_modes_1_and_2_log_from_the_start(tmp_path, mode, spans):
    bench = Bench(tmp_path, mode)
    bench.run(1.0)
    bench.arm(True)
    bench.run(1.0)
    bench.arm(False)
    bench.run(1.0)
    bench.arm(True)
    bench.run(1.0)
    logs = bench.logs()
    assert [span_s(log) for log in logs] == [pytest.approx(span, abs=0.01) for span in spans]


def test_a_new_plant_run_ends_the_log_and_a_refused_file_is_said_once(tmp_path):
    bench = Bench(tmp_path, 2)
    bench.run(1.0)
    bench.logger.restart()
    bench.state.time_usec = 0  # the plant's clock went back
    bench.run(0.5)
    assert [span_s(log)[0] for log in bench.logs()] == [pytest.approx(1.0025), pytest.approx(0.0025)]

    (tmp_path / "blocked").mkdir()
    (tmp_path / "blocked" / "log").write_text("a file where the log folder should be")
    blocked = Bench(tmp_path / "blocked", 2)
    blocked.run(1.0)
    assert len(blocked.notes) == 1 and "cannot create the log" in blocked.notes[0]
    assert blocked.logger.errors == 1 and blocked.logger.logging is None
