"""The preflight commands and the sensor streams as PX4 answers them, through MAVSDK and pymavlink: parameter reset
(MAV_CMD_PREFLIGHT_STORAGE, QGroundControl's "reset all to defaults"), gyro calibration through MAVSDK's
calibration plugin, HIGHRES_IMU at the rate MAVSDK's set_rate_imu asks for."""

from __future__ import annotations

import json
import threading
import time

import pytest

from transport.mavlink import mavlink as M

pytest.importorskip(
    "mavsdk", minversion="4", reason="MAVSDK-Python 4 (the native binding) is a test extra: pip install '.[test]'"
)

from mavsdk.plugins.calibration import Calibration, CalibrationResult  # noqa: E402
from mavsdk.plugins.telemetry import Telemetry  # noqa: E402

from tests.sitl.mavsdk_client import mavsdk_autopilot  # noqa: E402


def wait_file(path, predicate, timeout_s: float = 10.0) -> dict:
    deadline = time.monotonic() + timeout_s
    while True:
        document = json.loads(path.read_text()) if path.exists() else {}
        if predicate(document):
            return document
        assert time.monotonic() < deadline, f"{path}: {document}"
        time.sleep(0.05)


def test_reset_all_to_defaults_restores_them_and_the_file_says_so(vehicle_factory):
    vehicle = vehicle_factory(speed=0, params={"MPC_TKO_SPEED": 2.5, "SYS_FAILURE_EN": 1})
    gcs = vehicle.ground_station
    assert gcs.get_parameter("MPC_TKO_SPEED") == pytest.approx(2.5)
    gcs.arm()
    assert gcs.command(M.MAV_CMD_PREFLIGHT_STORAGE, 2, -1).result == M.MAV_RESULT_TEMPORARILY_REJECTED
    gcs.disarm()
    gcs.command_accepted(M.MAV_CMD_PREFLIGHT_STORAGE, 2, -1)  # QGroundControl's "reset all to defaults"
    assert gcs.get_parameter("MPC_TKO_SPEED") == pytest.approx(1.5)
    assert gcs.get_parameter("SYS_FAILURE_EN") == 0
    wait_file(vehicle.params_path, lambda document: document.get("parameters") == {})


def test_gyro_calibration_through_mavsdk_completes(vehicle_factory):
    vehicle = vehicle_factory(speed=2.0)
    results: list = []
    finished = threading.Event()

    def progress(result, data, user_data) -> None:
        results.append((result, data.progress if data.has_progress else None, data.status_text))
        if result != CalibrationResult.NEXT:
            finished.set()

    with mavsdk_autopilot(vehicle.mavsdk) as system:
        Calibration(system).calibrate_gyro_async(progress)
        assert finished.wait(60.0), f"no end of the calibration: {results}"
    assert results[-1][0] == CalibrationResult.SUCCESS, results
    assert any(p is not None and 0 < p < 1 for _, p, _ in results), results  # "[cal] progress <N>" seen
    print(f"gyro calibration: {len(results)} updates, {results[-1]}")
    stderr = vehicle.stderr()
    assert "[cal] calibration started: 2 gyro" in stderr and "[cal] calibration done: gyro" in stderr


def test_highres_imu_at_50_hz_after_set_rate_imu(vehicle_factory):
    vehicle = vehicle_factory(speed=2.0)
    stamps: list[int] = []
    imus: list = []
    with mavsdk_autopilot(vehicle.mavsdk) as system:
        telemetry = Telemetry(system)
        telemetry.set_rate_imu(50.0)
        telemetry.subscribe_imu(lambda imu, user_data: (stamps.append(imu.timestamp_us), imus.append(imu)))
        deadline = time.monotonic() + 60.0
        while len(stamps) < 2 or stamps[-1] - stamps[0] < 4_000_000:  # four simulated seconds, by their own stamps
            assert time.monotonic() < deadline, f"{len(stamps)} HIGHRES_IMU"
            time.sleep(0.05)
        taken = list(stamps)
    rate = (len(taken) - 1) / ((taken[-1] - taken[0]) / 1e6)
    print(f"HIGHRES_IMU on the API link: {rate:.2f} Hz over {len(taken)} messages")
    assert rate == pytest.approx(50.0, abs=1.0)
    imu = imus[-1]
    assert imu.acceleration_frd.down_m_s2 == pytest.approx(-9.81, abs=0.2)  # standing level, from HIL_SENSOR
    assert abs(imu.angular_velocity_frd.forward_rad_s) < 0.01
    gcs = vehicle.ground_station  # the GCS link: HIGHRES_IMU on request (it may come before the ACK is read)
    assert gcs.latest("HIGHRES_IMU") is None
    assert gcs.command(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_HIGHRES_IMU).result == M.MAV_RESULT_ACCEPTED
    deadline = time.monotonic() + 30.0
    while (requested := gcs.latest("HIGHRES_IMU")) is None:
        assert time.monotonic() < deadline, "no HIGHRES_IMU on the GCS link after MAV_CMD_REQUEST_MESSAGE"
        time.sleep(0.05)
    assert requested.zacc == pytest.approx(-9.81, abs=0.2)
