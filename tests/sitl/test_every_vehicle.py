"""Every vehicle, not only system id 1: the features a ground station uses on one vehicle (failure injection of a
motor, a servo and a sensor, parameters, Offboard, a mission uploaded and started, the truth feed, plant signing)
through MAVLink on system id 1, on a fleet member, on an instance's vehicle, on a vehicle whose MAV_SYS_ID was
changed and on an autopilot whose MAV_SYS_ID differs from its plant's system id; and on vehicle 3 of
`vtol up --count 3`. Each vehicle is addressed by its own system id, the MPC flying."""

from __future__ import annotations

import math
import os
import re
import signal
import socket
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from tests.sitl.ground_station import OFFBOARD, GroundStation, MissionClient, said
from tiltrotor_sitl import Fleet, ProcessOptions, TruthFeed, Vehicle, VehicleHandle
from tiltrotor_sitl.ground_station import encode_parameter
from transport.geodesy import LocalGeodetic
from transport.mavlink import mavlink as M
from transport.ports import MAX_SYSID, Ports

ALTITUDE = 30.0
PARAMS = {"SYS_FAILURE_EN": 1}
HOLD = (4 << 16) | (3 << 24)
MISSION = (4 << 16) | (4 << 24)
VTOL = os.path.join(os.path.dirname(sys.executable), "vtol")


def signing(tmp_path: Path) -> ProcessOptions:
    """Both processes given the same plant-link key (docs/plant-link.md#signing)."""
    key = tmp_path / "plant.key"
    key.write_text("c3" * 32)
    return ProcessOptions(
        plant_args=("--plant-signing-key", str(key)), autopilot_args=("--plant-signing-key", str(key))
    )


def ports_taken(ports: Ports) -> bool:
    for port in (ports.plant, ports.gcs_bind, ports.api_bind, ports.api_remote):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            try:
                probe.bind(("127.0.0.1", port))
            except OSError:
                return True
    return False


@contextmanager
def vehicle_under_test(case: str, tmp_path: Path) -> Iterator[VehicleHandle | _SplitVehicle]:
    """The vehicle each case names, hovering at ALTITUDE in Hold, with failure injection enabled."""
    common = {"spawn_alt": ALTITUDE, "speed": 3.0, "folder": tmp_path}
    if case == "sysid-1":
        with Vehicle(params=PARAMS, **common) as vehicle:
            assert vehicle.sysid == 1
            yield vehicle
    elif case == "fleet-member":
        with Fleet(3, params=PARAMS, **common, processes=signing(tmp_path)) as fleet:
            assert [v.sysid for v in fleet.vehicles] == [1, 2, 3]
            yield fleet.vehicles[2]
    elif case == "instance-3":
        if ports_taken(Ports(3)):
            pytest.skip("instance 3's ports are in use here")
        with Vehicle(instance=3, params=PARAMS, **common) as vehicle:
            assert vehicle.sysid == 4 and vehicle.ports.plant == 4563
            yield vehicle
    elif case == "mav-sys-id-42":
        with Vehicle(params={**PARAMS, "MAV_SYS_ID": 42}, **common, processes=signing(tmp_path)) as vehicle:
            assert vehicle.sysid == 42
            yield vehicle
    else:  # "split-ids": the autopilot is 42 by its MAV_SYS_ID, its plant 7: commands are addressed by the handshake
        with Vehicle(
            truth=True,
            spawn_alt=ALTITUDE,
            speed=3.0,
            folder=tmp_path / "plant",
            processes=ProcessOptions(autopilot=False, plant_args=("--sysid", "7")),
        ) as plant:
            with Vehicle(
                params={**PARAMS, "MAV_SYS_ID": 42},
                truth=False,
                spawn_alt=ALTITUDE,
                speed=3.0,
                folder=tmp_path / "autopilot",
                processes=ProcessOptions(plant_port=plant.ports.plant),
            ) as autopilot:
                assert autopilot.sysid == 42
                with TruthFeed(plant.ports.zenoh_plant, 7) as truth:
                    yield _SplitVehicle(autopilot, truth)


class _SplitVehicle:
    """An autopilot started alone, with the truth of the plant it flies (a plant of another system id): what the
    exercises read of a vehicle."""

    def __init__(self, autopilot: Vehicle, truth: TruthFeed) -> None:
        self.autopilot = autopilot
        self.truth = truth
        self.sysid, self.home, self.ports = autopilot.sysid, autopilot.home, autopilot.ports

    def stderr(self, process: str = "vtol-autopilot") -> str:
        return self.autopilot.stderr(process)


def ground_station(vehicle: VehicleHandle | _SplitVehicle) -> GroundStation:
    """A ground station that speaks first to the vehicle's own GCS port (a fleet's links share one remote port,
    where a listening ground station could not tell whose address to answer)."""
    gs = GroundStation(vehicle.ports.links.gcs_bind, vehicle.sysid, speaks_first=True)
    gs.connect()
    return gs


def inject(gs: GroundStation, unit: int, kind: int, instance: int, value: float = math.nan) -> None:
    ack = gs.command(M.MAV_CMD_INJECT_FAILURE, unit, kind, instance, value, timeout_s=30.0)
    assert (ack.command, ack.result) == (M.MAV_CMD_INJECT_FAILURE, M.MAV_RESULT_ACCEPTED), gs.statustexts[-3:]


def exercise_failure_injection(gs: GroundStation, truth: TruthFeed) -> None:
    """A motor, a servo and a sensor failed and cleared through MAVLink, each seen in the plant's truth. The
    controllers are told by the injection (VT_FAIL_ORACLE 1): a motor failure the detector finds stands until
    disarming, as PX4's, so the rotor would not spin again once cleared."""
    oracle = encode_parameter(1, M.MAV_PARAM_TYPE_INT32)
    assert gs.param_set("VT_FAIL_ORACLE", oracle, M.MAV_PARAM_TYPE_INT32).param_value == oracle
    inject(gs, 101, M.FAILURE_TYPE_OFF, 1)  # rotor 1 stops at once
    truth.wait_until(lambda s: s.rotor_speeds[0] == 0.0, 1.0, what="rotor 1 stopped")
    inject(gs, 101, M.FAILURE_TYPE_OK, 1)
    truth.wait_until(lambda s: s.rotor_speeds[0] > 100.0, 2.0, what="rotor 1 spinning again")
    inject(gs, 102, M.FAILURE_TYPE_STUCK, 1, 20.0)  # tilt servo 1 jammed at 20 deg
    truth.wait_until(lambda s: abs(s.tilts[0] - math.radians(20.0)) < 1e-9, 1.0, what="servo 1 at 20 deg")
    inject(gs, 102, M.FAILURE_TYPE_OK, 1)
    truth.wait_until(lambda s: abs(s.tilts[0] - math.radians(20.0)) > 0.1, 2.0, what="servo 1 moving again")
    inject(gs, 3, M.FAILURE_TYPE_OFF, 0)  # the barometer
    inject(gs, 3, M.FAILURE_TYPE_OK, 0)
    said(gs, "plant: baro all OK")  # the plant's text, passed on by the autopilot
    expected = ["plant: baro all OFF", "plant: baro all OK (cleared)"]
    gs.wait(lambda: [text for text in truth.failures if "baro" in text] == expected, f"{expected} on zenoh")
    truth.wait_until(lambda s: abs(s.altitude - ALTITUDE) < 3.0 and max(map(abs, s.velocity_ned)) < 1.0, 15.0,
                     what="hovering again")  # fmt: skip


def exercise_parameters(gs: GroundStation) -> None:
    assert gs.param_set("MIS_TAKEOFF_ALT", 7.5, M.MAV_PARAM_TYPE_REAL32).param_value == 7.5
    start = len(gs.param_values)
    gs.conn.mav.param_request_read_send(gs.vehicle, 1, b"MIS_TAKEOFF_ALT", -1)
    gs.wait(lambda: any(p.param_id == "MIS_TAKEOFF_ALT" for p in gs.param_values[start:]), "the read")
    assert [p.param_value for p in gs.param_values[start:] if p.param_id == "MIS_TAKEOFF_ALT"][0] == 7.5


def exercise_offboard(gs: GroundStation, truth: TruthFeed) -> None:
    def stream() -> None:
        gs.velocity_setpoint(2.0, 0.0, 0.0)

    gs.wait_sim(0.5, every=stream)
    assert gs.set_mode(OFFBOARD).result == M.MAV_RESULT_ACCEPTED
    gs.wait(lambda: gs.mode == OFFBOARD, "Offboard", every=stream)
    gs.wait_sim(4.0, every=stream)
    assert truth.latest().velocity_ned[0] == pytest.approx(2.0, abs=0.3)
    assert gs.set_mode(HOLD).result == M.MAV_RESULT_ACCEPTED


def exercise_mission(gs: GroundStation, vehicle: VehicleHandle | _SplitVehicle) -> None:
    """A one-waypoint mission 25 m north of where the vehicle holds, uploaded and started from the air."""
    here = vehicle.truth.latest()
    north = here.position_ned[0] + 25.0
    lat, lon, _ = LocalGeodetic(vehicle.home).to_geodetic(north, here.position_ned[1], 0.0)
    row = (M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, M.MAV_CMD_NAV_WAYPOINT, 0, 2.0, 0, math.nan,
           int(round(lat * 1e7)), int(round(lon * 1e7)), ALTITUDE)  # fmt: skip
    assert MissionClient(gs).upload(M.MAV_MISSION_TYPE_MISSION, [row]) == M.MAV_MISSION_ACCEPTED
    assert gs.set_mode(MISSION).result == M.MAV_RESULT_ACCEPTED
    vehicle.truth.wait_until(lambda s: abs(s.position_ned[0] - north) < 2.0, 40.0, what="the waypoint reached")


@pytest.mark.parametrize("case", ["sysid-1", "fleet-member", "instance-3", "mav-sys-id-42", "split-ids"])
def test_a_ground_station_reaches_every_feature_on_every_vehicle(case, tmp_path):
    with vehicle_under_test(case, tmp_path) as vehicle:
        gs = ground_station(vehicle)
        try:
            assert gs.latest["HEARTBEAT"].get_srcSystem() == vehicle.sysid and gs.armed and gs.mode == HOLD
            vehicle.truth.wait_until(lambda s: abs(s.altitude - ALTITUDE) < 1.0, 5.0, what="the hover")
            exercise_parameters(gs)
            exercise_failure_injection(gs, vehicle.truth)
            exercise_offboard(gs, vehicle.truth)
            exercise_mission(gs, vehicle)
        finally:
            gs.close()
        failed = [line for line in vehicle.stderr().splitlines() if "did not answer" in line or "refused" in line]
        assert failed == [], failed


def free_instances(count: int) -> int:
    """The first of `count` consecutive instances whose vehicle ports are free, below MAX_SYSID - count."""
    for first in range(100 + os.getpid() % 50, MAX_SYSID - count, count):
        if not any(ports_taken(Ports(first + i)) for i in range(count)):
            return first
    raise AssertionError("no free block of instances")


def test_vehicle_3_of_vtol_up_count_3_takes_its_failures(tmp_path):
    first = free_instances(3)
    third = Ports(first + 2)
    (tmp_path / "state").mkdir()
    with open(tmp_path / "vtol.stderr", "w") as stderr:
        vtol = subprocess.Popen([VTOL, "up", "--instance", str(first), "--count", "3", "--spawn-alt", str(ALTITUDE),
                                 "--speed", "2"], stdout=subprocess.DEVNULL, stderr=stderr, start_new_session=True,
                                env={**os.environ, "XDG_STATE_HOME": str(tmp_path / "state")})  # fmt: skip
    truth = None
    gs = GroundStation(third.gcs_bind, third.system_id, speaks_first=True)
    try:
        gs.connect()
        one = encode_parameter(1, M.MAV_PARAM_TYPE_INT32)  # PX4's bytewise INT32
        assert gs.param_set("SYS_FAILURE_EN", one, M.MAV_PARAM_TYPE_INT32).param_value == one
        truth = TruthFeed(third.zenoh_plant, third.system_id)
        exercise_failure_injection(gs, truth)
    finally:
        gs.close()
        if truth is not None:
            truth.close()
        os.killpg(vtol.pid, signal.SIGINT)
        vtol.wait(timeout=30)
    text = (tmp_path / "vtol.stderr").read_text()
    assert re.search(rf"vehicle {third.system_id} \(instance {third.instance}\)", text)
    assert "did not answer" not in text and "Traceback" not in text
