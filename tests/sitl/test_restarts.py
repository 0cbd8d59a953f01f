"""SIGKILL mid-flight (docs/faults.md, SIGKILL and restart): the autopilot, the plant and an Offboard client killed
while the vehicle flies; what the vehicle does, and the parameter and mission files intact afterwards."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

from tests.sitl.ground_station import HOLD, OFFBOARD, GroundStation
from tiltrotor_sitl import Vehicle
from transport.mavlink import mavlink as M

ALTITUDE = 30.0
REAL32 = M.MAV_PARAM_TYPE_REAL32


def heartbeat_from_a_new_process(gs: GroundStation, previous_heartbeats: int) -> None:
    gs.wait(lambda: len(gs.heartbeats) > previous_heartbeats and gs.armed, "a HEARTBEAT, armed", 60.0,
            every=gs.heartbeat)  # fmt: skip


def assert_hovering_in_hold(gs: GroundStation) -> None:
    assert gs.armed and gs.mode == HOLD
    assert abs(gs.altitude - ALTITUDE) < 1.5, gs.altitude
    assert all(abs(v) < 1.0 for v in gs.velocity), gs.velocity


def test_a_killed_autopilot_restarts_takes_the_plant_back_and_keeps_its_parameters(tmp_path):
    with Vehicle(spawn_alt=ALTITUDE, speed=2.0, truth=False, folder=tmp_path) as vehicle:
        gs = GroundStation(vehicle.gcs_port, vehicle.sysid)
        try:
            gs.connect()
            assert gs.param_set("COM_OF_LOSS_T", 2.5, REAL32).param_value == 2.5
            gs.wait_sim(1.0, every=gs.heartbeat)
            parameters_before = json.loads(vehicle.params_path.read_text())
            vehicle.process().send_signal(signal.SIGKILL)
            vehicle.process().wait(timeout=30)
            gs.pump(0.5)  # what the dead process sent is in our socket: read it, so the next HEARTBEAT is the new one's
            heard = len(gs.heartbeats)
            vehicle.restart()  # the plant waits, releases the dead peer, and the new autopilot takes it
            heartbeat_from_a_new_process(gs, heard)
            gs.wait_sim(2.0, every=gs.heartbeat)
            assert_hovering_in_hold(gs)
            asked = len(gs.param_values)
            gs.conn.mav.param_request_read_send(gs.vehicle, 1, b"COM_OF_LOSS_T", -1)
            gs.wait(lambda: any(p.param_id == "COM_OF_LOSS_T" for p in gs.param_values[asked:]), "COM_OF_LOSS_T")
            assert next(p for p in gs.param_values[asked:] if p.param_id == "COM_OF_LOSS_T").param_value == 2.5
        finally:
            gs.close()
        assert json.loads(vehicle.params_path.read_text()) == parameters_before
        assert "Traceback" not in vehicle.stderr() and "Traceback" not in vehicle.stderr("vtol-sim")


def test_a_killed_plant_restarts_and_the_autopilot_flies_on(tmp_path):
    with Vehicle(spawn_alt=ALTITUDE, speed=2.0, truth=False, folder=tmp_path) as vehicle:
        gs = GroundStation(vehicle.gcs_port, vehicle.sysid)
        try:
            gs.connect()
            gs.wait_sim(1.0, every=gs.heartbeat)
            vehicle.process("vtol-sim").send_signal(signal.SIGKILL)
            vehicle.process("vtol-sim").wait(timeout=30)
            # The autopilot waits for the silent plant, saying HELLO every 0.25 s, and after 1 s says so (wall time:
            # with no plant no simulated time passes).
            deadline = time.monotonic() + 60
            while "the plant is silent; waiting for it" not in vehicle.stderr():
                assert time.monotonic() < deadline and vehicle.process().poll() is None, vehicle.stderr()
                time.sleep(0.05)
            assert vehicle.running() is False and vehicle.process().poll() is None
            vehicle.restart("vtol-sim")  # a new plant, spawned as before, its clock from 0
            gs.wait(lambda: gs.sim_time < 1.0, "the new plant's clock", 60.0, every=gs.heartbeat)
            gs.wait_sim(2.0, every=gs.heartbeat)
            assert_hovering_in_hold(gs)
        finally:
            gs.close()
        stderr = vehicle.stderr()
        assert "the plant is silent; waiting for it" in stderr and "Traceback" not in stderr


CLIENT = """
import sys, time
from pymavlink import mavutil
link = mavutil.mavlink_connection(sys.argv[1], source_system=245)
link.wait_heartbeat(timeout=60)
print("streaming", flush=True)
while True:
    link.mav.set_position_target_local_ned_send(0, int(sys.argv[2]), 1, 1, 0x9C7, 0, 0, 0, 2.0, 0, 0, 0, 0, 0, 0, 0)
    time.sleep(0.05)
"""


def test_a_killed_offboard_client_leaves_the_vehicle_in_hold_after_com_of_loss_t(tmp_path):
    with Vehicle(spawn_alt=ALTITUDE, speed=2.0, truth=False, folder=tmp_path) as vehicle:
        gs = GroundStation(vehicle.gcs_port, vehicle.sysid)
        client = subprocess.Popen([sys.executable, "-c", CLIENT, vehicle.mavsdk.replace("udpin://", "udpin:"),
                                   str(vehicle.sysid)],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
        try:
            gs.connect()
            assert client.stdout is not None and client.stdout.readline().strip() == "streaming"
            gs.wait_sim(0.5, every=gs.heartbeat)
            assert gs.set_mode(OFFBOARD).result == M.MAV_RESULT_ACCEPTED
            gs.wait(lambda: gs.velocity[0] > 1.5, "2 m/s north", 60.0, every=gs.heartbeat)
            client.send_signal(signal.SIGKILL)
            client.wait(timeout=30)
            killed_at = gs.sim_time
            gs.wait(lambda: gs.mode != OFFBOARD, "the Offboard-loss failsafe", 60.0, every=gs.heartbeat)
            left_after = gs.sim_time - killed_at
            assert gs.mode == HOLD and gs.armed
            assert 0.8 < left_after < 2.0, left_after  # COM_OF_LOSS_T = 1 s after the last set-point
            assert any("offboard" in text.lower() for text in gs.statustexts)
            gs.wait(lambda: all(abs(v) < 0.5 for v in gs.velocity), "stopped", 60.0, every=gs.heartbeat)
        finally:
            gs.close()
            if client.poll() is None:
                os.kill(client.pid, signal.SIGKILL)
                client.wait()
