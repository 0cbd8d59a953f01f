"""The ground station helper (tiltrotor_sitl/ground_station.py) through real UDP: commands resent as PX4 and MAVSDK
resend them and matched to their COMMAND_ACK (against a scripted autopilot of another system id); on the real
vehicle a mission uploaded and flown, a refusal with its reason, a failure injected, parameters; a fleet's
vehicles each with their own; a vehicle behind faulty links (link_faults)."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable, Iterator

import pytest

from tiltrotor_sitl import (
    CommandRefused,
    CommandTimeout,
    Faults,
    Fleet,
    FlightMode,
    GroundStation,
    Vehicle,
    landing,
    waypoint,
)
from tiltrotor_sitl._free_ports import free_udp_port
from tiltrotor_sitl.ground_station import COMMAND_RETRIES, GroundLink
from transport.mavlink import Link
from transport.mavlink import mavlink as M
from transport.ports import LOOPBACK

SYSID = 7  # the scripted autopilot's: never a default of 1


class ScriptedAutopilot:
    """A vehicle of system id SYSID that says HEARTBEAT to `gcs_port` and answers each COMMAND_LONG as `answer`
    says (a list of (result, delay_s), possibly empty), noting each command's confirmation."""

    def __init__(self, gcs_port: int, answer: Callable[[int], list[tuple[int, float]]]) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((LOOPBACK, 0))
        self.sock.settimeout(0.05)
        self.gcs = (LOOPBACK, gcs_port)
        self.link = Link(SYSID, 1)
        self.other = Link(SYSID + 1, 1)  # a second vehicle on the same port: its ACKs are not ours
        self.answer = answer
        self.confirmations: list[int] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _send(self, link: Link, message) -> None:
        self.sock.sendto(link.pack(message), self.gcs)

    def _run(self) -> None:
        pending: list[tuple[float, int, int]] = []  # (due, command, result)
        clock = 0.0
        while not self._stop.is_set():
            clock += 0.05
            self._send(
                self.link, self.link.mav.heartbeat_encode(M.MAV_TYPE_VTOL_TILTROTOR, M.MAV_AUTOPILOT_PX4, 0, 0, 0)
            )
            try:
                data = self.sock.recv(65536)
            except TimeoutError:
                data = b""
            for message in self.link.parse(data):
                if message.get_type() == "COMMAND_LONG" and message.target_system == SYSID:
                    self.confirmations.append(message.confirmation)
                    # an ACK for another command, and one from another vehicle for this one: neither answers it
                    self._send(
                        self.link, self.link.mav.command_ack_encode(M.MAV_CMD_DO_SET_ROI_NONE, 0, 0, 0, 255, 190)
                    )
                    self._send(self.other, self.other.mav.command_ack_encode(message.command, M.MAV_RESULT_DENIED,
                                                                             0, 0, 255, 190))  # fmt: skip
                    for result, delay_s in self.answer(len(self.confirmations)):
                        pending.append((clock + delay_s, message.command, result))
            for due in [p for p in pending if p[0] <= clock]:
                pending.remove(due)
                self._send(self.link, self.link.mav.command_ack_encode(due[1], due[2], 0, 0, 255, 190))

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self.sock.close()


Answer = Callable[[int], list[tuple[int, float]]]


@pytest.fixture
def scripted() -> Iterator[Callable[[Answer], tuple[GroundStation, ScriptedAutopilot]]]:
    """scripted(answer) -> a ground station connected to a ScriptedAutopilot answering so, and the autopilot."""
    started: list[tuple[GroundLink, ScriptedAutopilot]] = []

    def start(answer: Answer) -> tuple[GroundStation, ScriptedAutopilot]:
        port = free_udp_port()
        link = GroundLink.listening(port)
        autopilot = ScriptedAutopilot(port, answer)
        started.append((link, autopilot))
        station = link.station(SYSID)
        station.wait_connected()
        return station, autopilot

    yield start
    for link, autopilot in started:
        autopilot.close()
        link.close()


def test_a_lost_command_is_resent_with_its_confirmation_counted_until_its_ack(scripted) -> None:
    station, autopilot = scripted(lambda sends: [(M.MAV_RESULT_ACCEPTED, 0.0)] if sends == 3 else [])
    ack = station.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1.0)
    assert (ack.command, ack.result, ack.get_srcSystem()) == (M.MAV_CMD_COMPONENT_ARM_DISARM, M.MAV_RESULT_ACCEPTED,
                                                              SYSID)  # fmt: skip
    assert autopilot.confirmations == [0, 1, 2]


def test_in_progress_waits_for_the_final_answer_without_resending(scripted) -> None:
    station, autopilot = scripted(lambda sends: [(M.MAV_RESULT_IN_PROGRESS, 0.0), (M.MAV_RESULT_ACCEPTED, 1.5)])
    assert station.command(M.MAV_CMD_PREFLIGHT_CALIBRATION, 1.0).result == M.MAV_RESULT_ACCEPTED
    assert autopilot.confirmations == [0]


def test_a_command_never_answered_times_out_after_the_retries_and_a_refusal_is_raised(scripted) -> None:
    station, autopilot = scripted(lambda sends: [])
    with pytest.raises(CommandTimeout, match="MAV_CMD_NAV_LAND: no COMMAND_ACK from vehicle 7 after 4 sends"):
        station.land()
    assert autopilot.confirmations == list(range(COMMAND_RETRIES + 1))
    refusing, _ = scripted(lambda sends: [(M.MAV_RESULT_TEMPORARILY_REJECTED, 0.0)])
    with pytest.raises(CommandRefused, match="MAV_CMD_COMPONENT_ARM_DISARM refused by vehicle 7 "
                                             r"\(MAV_RESULT_TEMPORARILY_REJECTED\)") as refused:  # fmt: skip
        refusing.arm()
    assert refused.value.result == M.MAV_RESULT_TEMPORARILY_REJECTED


def test_the_helpers_fly_a_mission_say_refusals_and_inject_failures(tmp_path) -> None:
    with Vehicle(speed=None, folder=tmp_path) as vehicle:
        gcs = vehicle.ground_station
        assert gcs.mode is FlightMode.HOLD and not gcs.armed
        with pytest.raises(CommandRefused, match="Mode ACRO not supported"):
            gcs.set_mode("ACRO")
        assert gcs.set_parameter("MIS_TAKEOFF_ALT", 12.0) == 12.0 and gcs.get_parameter("MIS_TAKEOFF_ALT") == 12.0
        home = vehicle.home
        gcs.upload_mission([waypoint(home, 40.0, 0.0, 12.0, acceptance_m=2.0), landing(home, 40.0, 0.0)])
        gcs.set_mode(FlightMode.MISSION)
        gcs.arm()
        vehicle.truth.wait_until(lambda s: s.on_ground and s.position_ned[0] > 35.0, timeout_sim_s=180,
                                 what="landed at the mission's end")  # fmt: skip
        flight = vehicle.truth.trajectory()
        assert 11.0 < flight.altitude.max() < 13.5
        assert abs(flight.position_ned[-1, 0] - 40.0) < 2.0 and abs(flight.position_ned[-1, 1]) < 2.0
        gcs.inject_failure("motor", "off", 1)
        assert gcs.get_parameter("SYS_FAILURE_EN") == 1
        vehicle.truth.wait_until(lambda s: s.rotor_speeds[0] == 0.0, timeout_sim_s=2.0, what="rotor 1 stopped")
        with pytest.raises(ValueError, match="motor instance 9 not in 0..4"):
            gcs.inject_failure("motor", "off", 9)


def test_each_vehicle_of_a_fleet_has_its_own_ground_station_on_the_one_link(tmp_path) -> None:
    with Fleet(2, speed=None, folder=tmp_path) as fleet:
        stations = [vehicle.ground_station for vehicle in fleet]
        assert [station.target_system for station in stations] == [1, 2]
        assert stations[0].link is stations[1].link
        fleet[1].ground_station.arm()
        fleet[1].truth.wait_until(lambda s: s.rotor_speeds[0] > 100.0, timeout_sim_s=5.0, what="vehicle 2 armed")
        stations[1].wait_message("HEARTBEAT", lambda heartbeat: heartbeat.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED)
        assert stations[1].armed and not stations[0].armed


def test_link_faults_sit_on_both_links_both_ways_and_change_in_flight(tmp_path) -> None:
    lossy = Faults(loss=0.05, duplicate=0.1, reorder=0.05, jitter_s=0.005)
    with Vehicle(speed=2.0, folder=tmp_path, link_faults=lossy) as vehicle:
        gcs = vehicle.ground_station
        for _ in range(3):  # a round trip is lost 1 time in 10: a lost one is resent (3 lost in a row: 1 in 10^4)
            gcs.set_mode(FlightMode.HOLD)
        # 5 % lost, 10 % duplicated: seen once enough telemetry has gone through (a few round trips may carry
        # only some dozens of datagrams, none of them lost)
        deadline = time.monotonic() + 30.0
        while True:
            counts = vehicle.link_fault_counts()
            if counts["gcs"]["to_ground"]["lost"] > 0 and counts["gcs"]["to_ground"]["duplicated"] > 0:
                break
            assert time.monotonic() < deadline, counts["gcs"]["to_ground"]
            time.sleep(0.1)
        assert counts["gcs"]["to_vehicle"]["received"] >= 3  # our commands and HEARTBEATs went through it
        assert counts["api"]["to_ground"]["received"] > 0  # the API link's telemetry, MAVSDK's side
        vehicle.set_link_faults(to_vehicle=Faults(loss=1.0), to_ground=Faults())
        with pytest.raises(CommandTimeout, match="no COMMAND_ACK from vehicle 1 after 4 sends"):
            gcs.arm()
        assert gcs.next_message("HEARTBEAT", timeout_s=10.0) is not None  # the vehicle's messages still arrive
        assert not gcs.armed
