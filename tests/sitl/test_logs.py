"""The flight log as a PX4 user gets it: a takeoff, an Offboard leg and a landing flown by the MPC through MAVLink,
the ULog downloaded with MAVSDK's log_files plugin and with pymavlink's LOG_* messages, read with pyulog: PX4's
topics and fields, the attitude and position of the plant's truth at the same times, the vehicle's parameters (and
a change in flight), the STATUSTEXTs; and `vtol up --log-dir`."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip(
    "mavsdk", minversion="4", reason="MAVSDK-Python 4 (the native binding) is a test extra: pip install '.[test]'"
)
pyulog = pytest.importorskip("pyulog", reason="pyulog is a test extra: pip install '.[test]'")

from mavsdk.plugins.log_files import LogFiles, LogFilesResult  # noqa: E402

from tests.sitl.ground_station import GroundStation  # noqa: E402
from tests.sitl.mavsdk_client import mavsdk_autopilot  # noqa: E402
from tests.sitl.test_vtol_up import VTOL, free_instance  # noqa: E402
from tiltrotor_sitl import PlantTruth, ProcessOptions, Vehicle  # noqa: E402
from transport.geodesy import LocalGeodetic  # noqa: E402
from transport.mavlink import mavlink  # noqa: E402
from transport.ports import Ports  # noqa: E402
from transport.telemetry import plant_state_key  # noqa: E402
from transport.zenoh_bus import session_config  # noqa: E402

OFFBOARD = 6 << 16
# PX4 v1.15's fields (msg/*.msg) a user's tools read, topic by topic.
PX4_FIELDS = {
    "vehicle_attitude": ["timestamp", "timestamp_sample", "q[0]", "q[3]", "delta_q_reset[0]", "quat_reset_counter"],
    "vehicle_attitude_setpoint": [
        "roll_body",
        "pitch_body",
        "yaw_body",
        "yaw_sp_move_rate",
        "q_d[0]",
        "thrust_body[2]",
    ],
    "vehicle_rates_setpoint": ["roll", "pitch", "yaw", "thrust_body[2]", "reset_integral"],
    "vehicle_local_position": [
        "x",
        "y",
        "z",
        "vx",
        "vy",
        "vz",
        "ax",
        "az",
        "heading",
        "xy_valid",
        "ref_lat",
        "ref_lon",
        "ref_alt",
        "eph",
        "dead_reckoning",
        "vxy_max",
        "hagl_max",
    ],
    "vehicle_local_position_setpoint": ["x", "vx", "vy", "vz", "acceleration[0]", "thrust[2]", "yaw", "yawspeed"],
    "trajectory_setpoint": [
        "position[0]",
        "velocity[0]",
        "velocity[2]",
        "acceleration[0]",
        "jerk[0]",
        "yaw",
        "yawspeed",
    ],
    "vehicle_global_position": ["lat", "lon", "alt", "alt_ellipsoid", "eph", "terrain_alt_valid"],
    "vehicle_status": [
        "arming_state",
        "nav_state",
        "vehicle_type",
        "is_vtol",
        "in_transition_mode",
        "failsafe",
        "system_id",
        "pre_flight_checks_pass",
    ],
    "vtol_vehicle_status": ["vehicle_vtol_state", "fixed_wing_system_failure"],
    "actuator_motors": ["timestamp_sample", "reversible_flags", "control[0]", "control[11]"],
    "actuator_servos": ["timestamp_sample", "control[0]", "control[7]"],
    "actuator_outputs": ["noutputs", "output[0]", "output[15]"],
    "sensor_combined": ["gyro_rad[0]", "gyro_integral_dt", "accelerometer_m_s2[2]", "accelerometer_integral_dt"],
    "battery_status": ["connected", "voltage_v", "remaining", "cell_count", "voltage_cell_v[0]", "warning"],
    "failure_detector_status": ["fd_roll", "fd_motor", "motor_failure_mask"],
    "home_position": ["lat", "lon", "alt", "x", "y", "z", "valid_hpos", "manual_home"],
    "mission_result": ["seq_reached", "seq_current", "seq_total", "valid", "finished"],
    "tiltrotor_mpc_status": ["solve_time_ms", "qp_iterations", "ok", "hpipm_status"],
}


class TruthRecorder:
    """Every state the plant publishes on zenoh, by its time (us)."""

    def __init__(self, endpoint: str, system_id: int) -> None:
        import zenoh

        self.states: dict[int, PlantTruth] = {}
        self._lock = threading.Lock()
        self._session: Any = zenoh.open(session_config(listen=[], connect=[endpoint]))
        self._subscriber = self._session.declare_subscriber(plant_state_key(system_id), self._on_state)

    def _on_state(self, sample: Any) -> None:
        states = PlantTruth.all_from_payload(sample.payload.to_bytes())
        with self._lock:
            for state in states:
                self.states[int(round(state.t * 1e6))] = state

    def close(self) -> None:
        self._subscriber.undeclare()
        self._session.close()


def download_with_pymavlink(gs: GroundStation, timeout_s: float = 120.0) -> tuple[list[Any], bytes]:
    """LOG_REQUEST_LIST, then the newest log by LOG_REQUEST_DATA (missing pieces asked for again), LOG_REQUEST_END."""
    mav = gs.conn.mav
    with gs.recording("LOG_ENTRY") as entries:
        mav.log_request_list_send(gs.vehicle, 1, 0, 0xFFFF)
        gs.wait(lambda: entries and len(entries) == entries[0].num_logs, "LOG_ENTRYs", 30.0)
    newest = max(entries, key=lambda entry: entry.id)
    received: dict[int, bytes] = {}
    deadline = time.monotonic() + timeout_s
    with gs.recording("LOG_DATA") as data:
        while sum(len(piece) for piece in received.values()) < newest.size:
            assert time.monotonic() < deadline, "the log did not arrive"
            missing = next(ofs for ofs in range(0, newest.size, 90) if ofs not in received)
            mav.log_request_data_send(gs.vehicle, 1, newest.id, missing, newest.size - missing)
            gs.pump(0.5)
            for message in data:
                if message.id == newest.id and message.count:
                    received[message.ofs] = bytes(message.data[: message.count])
            data.clear()
    mav.log_request_end_send(gs.vehicle, 1)
    return entries, b"".join(received[ofs] for ofs in sorted(received))


def download_with_mavsdk(api_port: int, target: Path) -> list:
    with mavsdk_autopilot(f"udpin://127.0.0.1:{api_port}") as system:
        log_files = LogFiles(system)
        entries = log_files.get_entries()
        done = threading.Event()
        outcome: list[LogFilesResult] = []

        def progress(result: LogFilesResult, data: Any, user_data: Any) -> None:
            if result != LogFilesResult.NEXT:
                outcome.append(result)
                done.set()

        log_files.download_log_file_async(entries[-1], str(target), progress)
        assert done.wait(180.0), "MAVSDK's download did not end"
        assert outcome == [LogFilesResult.SUCCESS]
        return entries


def parameter_values(gs: GroundStation) -> dict[str, float]:
    """Every parameter by PARAM_REQUEST_LIST, INT32 ones decoded from PX4's bytewise encoding."""
    with gs.recording("PARAM_VALUE") as values:
        gs.conn.mav.param_request_list_send(gs.vehicle, 1)
        gs.wait(lambda: values and len({v.param_id for v in values}) == values[0].param_count, "every PARAM_VALUE")
    decoded = {}
    for value in values:
        if value.param_type == mavlink.MAV_PARAM_TYPE_INT32:
            decoded[value.param_id] = float(np.frombuffer(np.float32(value.param_value).tobytes(), np.int32)[0])
        else:
            decoded[value.param_id] = float(np.float32(value.param_value))
    return decoded


def quantised(geodetic: LocalGeodetic, position: tuple[float, float, float]) -> np.ndarray:
    """A truth position as HIL_STATE_QUATERNION carries it to the autopilot (degE7, mm) and back to NED."""
    lat, lon, alt = geodetic.to_geodetic(*position)
    return np.array(geodetic.to_ned(round(lat * 1e7) * 1e-7, round(lon * 1e7) * 1e-7, round(alt * 1e3) * 1e-3))


def test_a_flight_log_downloaded_and_read_as_px4s(tmp_path):
    vehicle = Vehicle(controller="mpc", speed=4.0, truth=True, folder=tmp_path, processes=ProcessOptions(summary=True),
                      params={"MIS_TAKEOFF_ALT": 5.0, "COM_DISARM_LAND": 1.0}).start()  # fmt: skip
    truth = TruthRecorder(vehicle.ports.zenoh_plant, vehicle.sysid)
    gs = GroundStation(vehicle.gcs_port, vehicle.sysid)
    try:
        gs.connect()
        assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == mavlink.MAV_RESULT_ACCEPTED
        takeoff = gs.command(mavlink.MAV_CMD_NAV_TAKEOFF, *([math.nan] * 7))
        assert takeoff.result == mavlink.MAV_RESULT_ACCEPTED
        gs.wait(lambda: gs.altitude > 4.7, "the takeoff to 5 m", 120.0)
        north = lambda: gs.velocity_setpoint(3.0, 0.0, 0.0)  # noqa: E731
        north()
        assert gs.set_mode(OFFBOARD).result == mavlink.MAV_RESULT_ACCEPTED
        gs.wait_sim(2.0, every=north, timeout_s=60.0)
        changed = gs.param_set("MPC_XY_P", 0.8, mavlink.MAV_PARAM_TYPE_REAL32)  # a change in flight
        assert changed.param_value == pytest.approx(0.8)
        gs.wait_sim(3.0, every=north, timeout_s=60.0)
        assert gs.command(mavlink.MAV_CMD_NAV_LAND).result == mavlink.MAV_RESULT_ACCEPTED
        gs.wait(lambda: not gs.armed, "landing and disarming", 180.0)
        gs.wait_sim(1.0)  # the log ends a step after the disarming, and its writer catches up
        said = list(gs.statustexts)
        values = parameter_values(gs)

        on_disk = vehicle.logs()
        assert len(on_disk) == 1 and on_disk[0].parent.parent == vehicle.log_dir
        mavsdk_copy = tmp_path / "mavsdk.ulg"
        mavsdk_entries = download_with_mavsdk(vehicle.api_port, mavsdk_copy)
        entries, pymavlink_copy = download_with_pymavlink(gs)
    finally:
        gs.close()
        truth.close()
        vehicle.stop()

    log = on_disk[0].read_bytes()
    assert len(mavsdk_entries) == 1 and mavsdk_entries[0].size_bytes == len(log)
    assert entries[0].num_logs == 1 and entries[0].size == len(log) and entries[0].time_utc > 0
    assert mavsdk_copy.read_bytes() == log
    assert pymavlink_copy == log

    ulog = pyulog.ULog(str(mavsdk_copy))
    datasets = {d.name: d for d in ulog.data_list}
    for topic, fields in PX4_FIELDS.items():
        assert topic in datasets, f"{topic} not logged"
        missing = set(fields) - set(datasets[topic].data)
        assert not missing, f"{topic} lacks PX4's {sorted(missing)}"
    status = datasets["vehicle_status"].data
    assert set(status["arming_state"][:-1]) == {2}  # SDLOG_MODE 0: from arming to disarming (the last may say it)
    assert 14 in set(status["nav_state"])  # NAVIGATION_STATE_OFFBOARD
    assert set(datasets["tiltrotor_mpc_status"].data["ok"]) == {1}

    # The attitude and position at the same times as the plant's truth.
    geodetic = LocalGeodetic(vehicle.home)
    attitude, position = datasets["vehicle_attitude"].data, datasets["vehicle_local_position"].data
    compared = 0
    for i, t in enumerate(attitude["timestamp"]):
        state = truth.states.get(int(t))
        if state is None:
            continue
        q = np.array([attitude[f"q[{k}]"][i] for k in range(4)])
        assert np.max(np.abs(q - np.array(state.quaternion))) < 1e-3, f"attitude at {t} us"
        compared += 1
    for i, t in enumerate(position["timestamp"]):
        state = truth.states.get(int(t))
        if state is None:
            continue
        logged = np.array([position[axis][i] for axis in ("x", "y", "z")])
        assert np.max(np.abs(logged - quantised(geodetic, state.position_ned))) < 1e-3, f"position at {t} us"
        assert np.max(np.abs(logged - np.array(state.position_ned))) < 0.02  # within HIL_STATE's degE7 and mm
        compared += 1
    assert compared > 0.8 * (len(attitude["timestamp"]) + len(position["timestamp"]))
    assert max(-position["z"]) > 4.5 and max(position["x"]) > 5.0  # the takeoff and the leg north

    # The parameters: the vehicle's values, the change in flight.
    assert set(ulog.initial_parameters) == set(values)
    final = dict(ulog.initial_parameters) | {name: value for _, name, value in ulog.changed_parameters}
    for name, value in values.items():
        assert final[name] == pytest.approx(value, rel=1e-6), name
    assert ulog.initial_parameters["MPC_XY_P"] == pytest.approx(0.95)
    assert [(name, round(value, 3)) for _, name, value in ulog.changed_parameters] == [("MPC_XY_P", 0.8)]

    # The STATUSTEXTs of the flight, from the arming to the disarming.
    logged = [message.message for message in ulog.logged_messages]
    first, last = said.index("Armed"), max(i for i, text in enumerate(said) if text.startswith("Disarmed"))
    for text in said[first : last + 1]:
        assert text in logged, f"STATUSTEXT {text!r} not in the log"


def test_vtol_up_writes_the_ulogs_to_its_log_dir(tmp_path):
    instance = free_instance()
    ports = Ports(instance)
    gs = GroundStation(ports.gcs_remote, ports.system_id)
    command = [VTOL, "up", "--instance", str(instance), "--spawn-alt", "10", "--speed", "4", "--controller", "pid",
               "--no-zenoh", "--params", str(tmp_path / "params.json"), "--log-dir", str(tmp_path / "logs")]  # fmt: skip
    vtol = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        gs.connect(timeout_s=60)
        assert gs.armed  # spawned in the air: SDLOG_MODE 0 logs from the first step
        gs.wait_sim(2.0)
        os.killpg(vtol.pid, signal.SIGINT)
        assert vtol.wait(timeout=20) == 0
    finally:
        if vtol.poll() is None:
            os.killpg(vtol.pid, signal.SIGKILL)
            vtol.wait()
        gs.close()
    (log,) = (tmp_path / "logs").glob("*/*.ulg")
    parsed = pyulog.ULog(str(log))
    assert not parsed.file_corruption and parsed.last_timestamp - parsed.start_timestamp > 2_000_000
    assert (tmp_path / f"microsd-{instance}" / "etc" / "extras" / "parameters.json").is_file()  # the default root
