"""The ULog writer read back by pyulog, the logged topics' samples, the log file's bounded writer, the vehicle's
files, and log download without sockets (a link that keeps what is queued)."""

from __future__ import annotations

import datetime as dt
import io
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from aircraft.failures import Failure, FailureType, FailureUnit
from autopilot.control.attitude import DEFAULT_GAINS, AttitudeGains
from autopilot.logger import samples, ulog
from autopilot.logger.log_file import MAX_PENDING_BYTES, Chunk, LogFile
from autopilot.logger.topics import TOPICS, VEHICLE_ATTITUDE
from autopilot.mavlink.log_download import LogDownloadService
from autopilot.storage.vehicle_files import VehicleFiles, log_relative_path
from autopilot.topics.flight_mode import ModeId
from autopilot.topics.home_position import HomePosition
from autopilot.topics.missions import Missions
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.yaw_setpoint import YawReference
from transport.geodesy import Home, LocalGeodetic
from transport.mavlink import Link
from transport.mavlink import mavlink as M

pyulog = pytest.importorskip("pyulog", reason="pyulog is a test extra: pip install '.[test]'")


class QueueLink:
    """What a service needs of a GroundLink: an encoder, and a queue (kept here)."""

    def __init__(self) -> None:
        self.mav = Link(1, 1).mav
        self.sent: list = []

    def queue(self, message) -> None:
        self.sent.append(message)


def read(data: bytes):
    return pyulog.ULog(io.BytesIO(data))


def test_every_ulog_message_is_read_back_by_pyulog():
    attitude = VEHICLE_ATTITUDE
    data = b"".join([
        ulog.file_header(1_000), ulog.flag_bits(), ulog.info_string("sys_name", "tiltrotor-sitl"),
        ulog.info_uint32("ver_sw_release", 0x010F00FF), ulog.info_int32("time_ref_utc", -3600),
        *(ulog.format_definition(topic.name, topic.fields) for topic in TOPICS),
        ulog.parameter("SYS_FAILURE_EN", 1, True), ulog.parameter("MPC_XY_P", 0.95, False),
        ulog.parameter_default("SYS_FAILURE_EN", 0, True), ulog.parameter_default("MPC_XY_P", 0.95, False),
        ulog.subscription(0, attitude.name), ulog.logged_string(M.MAV_SEVERITY_WARNING, 1_500, "Armed"),
        ulog.data(0, attitude.pack((2_000, 2_000, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0))), ulog.sync(),
        ulog.dropout(120), ulog.parameter("MPC_XY_P", 0.8, False),
        ulog.data(0, attitude.pack((3_000, 3_000, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0))),
    ])  # fmt: skip
    log = read(data)
    assert log.start_timestamp == 1_000
    assert log.msg_info_dict["sys_name"] == "tiltrotor-sitl" and log.msg_info_dict["time_ref_utc"] == -3600
    assert log.msg_info_dict["ver_sw_release"] == 0x010F00FF
    assert log.initial_parameters == {"SYS_FAILURE_EN": 1, "MPC_XY_P": pytest.approx(0.95)}
    assert log.get_default_parameters(0) == {"SYS_FAILURE_EN": 0, "MPC_XY_P": pytest.approx(0.95)}
    assert [(name, round(value, 3)) for _, name, value in log.changed_parameters] == [("MPC_XY_P", 0.8)]
    assert [(m.log_level_str(), m.timestamp, m.message) for m in log.logged_messages] == [("WARNING", 1_500, "Armed")]
    assert [d.duration for d in log.dropouts] == [120]
    q = log.get_dataset("vehicle_attitude").data
    assert q["timestamp"].tolist() == [2_000, 3_000] and q["q[1]"].tolist() == [0.0, 1.0]
    assert set(log.message_formats) == {topic.name for topic in TOPICS}


def test_a_message_too_long_for_ulog_is_refused():
    with pytest.raises(ulog.ULogError):
        ulog.format_definition("x", "float y;" * 10_000)
    assert len(ulog.logged_string(6, 0, "x" * 100_000)) == 0xFFFF + 3  # a text is cut to what fits


def state_in_flight() -> VehicleState:
    state = VehicleState(time_usec=5_000_000, valid=True)
    state.position_ned[:] = (10.0, -4.0, -20.0)
    state.velocity_ned[:] = (3.0, 0.5, -0.2)
    state.quaternion[:] = (0.9659258, 0.0, 0.0, 0.2588190)  # 30 deg yaw
    state.euler[:] = (0.0, 0.0, np.radians(30.0))
    state.body_rates[:] = (0.01, -0.02, 0.1)
    state.specific_force[:] = (0.0, 0.0, -9.81)
    return state


def test_each_topic_packs_its_sample_and_the_samples_say_what_px4_would():
    state, home, t = state_in_flight(), Home(47.397742, 8.545594, 488.0), 5_000_000
    yaw = YawReference(0.5, 0.1)
    pwm = [1500, 1510, 1490, 1500, 1000, 1250, 1500, 2000, 1500, 1500, 1500, 1500]
    failures = [Failure(FailureUnit.MOTOR, FailureType.OFF, 2), Failure(FailureUnit.SERVO, FailureType.STUCK, 1)]
    thrust = samples.normalised_thrust(np.array([0.0, 0.0, -80.0]), 160.0)
    built = {
        "vehicle_attitude": samples.vehicle_attitude(t, state),
        "vehicle_attitude_setpoint": samples.vehicle_attitude_setpoint(t, np.array([0.1, -0.1, 0.5]), thrust, yaw),
        "vehicle_rates_setpoint": samples.vehicle_rates_setpoint(t, (0.1, 0.2, 0.3), thrust),
        "vehicle_local_position": samples.vehicle_local_position(
            t, state, samples.acceleration_ned(state, 9.81), home, 1_000
        ),  # fmt: skip
        "vehicle_local_position_setpoint": samples.vehicle_local_position_setpoint(
            t, np.array([3.0, 0.0, 0.0]), (0.0, 0.0, -0.5), np.array([0.1, -0.1, 0.5]), yaw
        ),  # fmt: skip
        "trajectory_setpoint": samples.trajectory_setpoint(t, np.array([3.0, 0.0, 0.0]), None),
        "vehicle_global_position": samples.vehicle_global_position(t, state, LocalGeodetic(home)),
        "vehicle_status": samples.vehicle_status(
            t,
            armed=True,
            armed_usec=1,
            takeoff_usec=2,
            nav=14,
            nav_usec=3,
            valid_modes=1 << 14,
            fixed_wing=False,
            transition=1,
            failsafe=False,
            datalink_lost=False,
            system_id=1,
            started=True,
        ),  # fmt: skip
        "vtol_vehicle_status": samples.vtol_vehicle_status(t, M.MAV_VTOL_STATE_MC),
        "actuator_motors": samples.actuator_motors(t, pwm),
        "actuator_servos": samples.actuator_servos(t, pwm),
        "actuator_outputs": samples.actuator_outputs(t, pwm),
        "sensor_combined": samples.sensor_combined(t, state),
        "battery_status": samples.battery_status(t),
        "failure_detector_status": samples.failure_detector_status(t, samples.motor_failure_mask(failures)),
        "home_position": samples.home_position(t, HomePosition(47.0, 8.0, 500.0, 1.0, 2.0, -3.0, True), 4),
        "mission_result": samples.mission_result(t, Missions(), 1, 2, 3),
        "tiltrotor_mpc_status": samples.mpc_status(t, 0.4, 3, 1.5, True, False, "SUCCESS"),
    }
    assert set(built) == {topic.name for topic in TOPICS}
    data = [ulog.file_header(0), ulog.flag_bits()]
    data += [ulog.format_definition(topic.name, topic.fields) for topic in TOPICS]
    data += [ulog.subscription(i, topic.name) for i, topic in enumerate(TOPICS)]
    data += [ulog.data(i, topic.pack(built[topic.name])) for i, topic in enumerate(TOPICS)]
    log = read(b"".join(data))
    got = {d.name: {k: v[0] for k, v in d.data.items()} for d in log.data_list}
    assert got["vehicle_local_position"]["x"] == 10.0 and got["vehicle_local_position"]["z"] == -20.0
    assert got["vehicle_local_position"]["heading"] == pytest.approx(np.radians(30.0))
    assert got["vehicle_local_position"]["az"] == pytest.approx(0.0, abs=1e-5)  # hovering: no acceleration
    assert got["vehicle_local_position"]["ref_lat"] == home.lat
    lat, lon, alt = LocalGeodetic(home).to_geodetic(10.0, -4.0, -20.0)
    assert got["vehicle_global_position"]["lat"] == lat and got["vehicle_global_position"]["alt"] == pytest.approx(alt)
    assert got["actuator_motors"]["control[1]"] == pytest.approx(0.51) and np.isnan(
        got["actuator_motors"]["control[4]"]
    )
    assert got["actuator_servos"]["control[0]"] == -1.0 and got["actuator_servos"]["control[3]"] == 1.0
    assert got["actuator_outputs"]["noutputs"] == 12 and got["actuator_outputs"]["output[7]"] == 2000.0
    assert got["failure_detector_status"]["motor_failure_mask"] == 0b10 and got["failure_detector_status"]["fd_motor"]
    assert got["vehicle_status"]["in_transition_to_fw"] and got["vehicle_status"]["system_type"] == 21
    assert got["trajectory_setpoint"]["velocity[0]"] == 3.0 and np.isnan(got["trajectory_setpoint"]["position[0]"])
    assert got["vehicle_attitude_setpoint"]["yaw_sp_move_rate"] == pytest.approx(0.1)
    assert got["vehicle_attitude_setpoint"]["thrust_body[2]"] == -0.5
    assert got["home_position"]["manual_home"] and got["home_position"]["update_count"] == 4
    assert got["tiltrotor_mpc_status"]["hpipm_status"] == 0
    assert samples.mpc_status(t, 1.0, 1, 0.0, False, False, "NAN_SOL")[-1] == 3


def test_navigation_states_and_motor_failures_as_px4_numbers_them():
    assert samples.nav_state(ModeId("Hold", 4, 3), False) == samples.NAV_STATE_AUTO_LOITER
    assert samples.nav_state(ModeId("Offboard", 6), False) == samples.NAV_STATE_OFFBOARD
    assert samples.nav_state(ModeId("Orbit", 3, 1), False) == samples.NAV_STATE_ORBIT
    assert samples.nav_state(ModeId("Follow Me", 4, 8), False) == samples.NAV_STATE_AUTO_FOLLOW_TARGET == 19
    assert samples.nav_state(ModeId("Hold", 4, 3), True) == samples.NAV_STATE_TERMINATION
    assert samples.nav_states_mask((ModeId("Hold", 4, 3), ModeId("Land", 4, 6))) == (1 << 4) | (1 << 18)
    off, ok = FailureType.OFF, FailureType.OK
    assert samples.motor_failure_mask([Failure(FailureUnit.MOTOR, off, 0)]) == 0b1111
    assert samples.motor_failure_mask([Failure(FailureUnit.MOTOR, off, 0), Failure(FailureUnit.MOTOR, ok, 3)]) == 0b1011


def test_the_rate_setpoint_is_the_attitude_loops_p_law():
    rate_setpoint = samples.BodyRateSetpoint()
    rates = rate_setpoint(np.zeros(3), np.array([0.0, 0.0, 0.1]), DEFAULT_GAINS)
    assert rates == pytest.approx([0.0, 0.0, np.pi * np.tanh(3.0 * 0.1 / np.pi)])  # yaw: 3 1/s, limited to pi
    tuned = rate_setpoint(np.zeros(3), np.array([0.0, 0.0, 0.1]), AttitudeGains(attitude=(6.0, 6.0, 5.0)))
    assert tuned == pytest.approx([0.0, 0.0, np.pi * np.tanh(5.0 * 0.1 / np.pi)])  # MC_YAW_P as set


class SlowDisk(io.BytesIO):
    """A file whose writes wait until released (a disk that has stalled)."""

    def __init__(self) -> None:
        super().__init__()
        self.released = threading.Event()

    def write(self, data) -> int:
        self.released.wait(10.0)
        return super().write(data)

    def close(self) -> None:
        self.content = self.getvalue()
        super().close()


def test_a_stalled_disk_costs_samples_not_memory_and_the_log_says_so(tmp_path):
    disk = SlowDisk()
    file = LogFile(tmp_path / "x.ulg", disk)
    chunk = bytes(1024 * 1024)
    for i in range(2 * MAX_PENDING_BYTES // len(chunk)):
        file.submit(Chunk(chunk, i * 1_000_000, (i + 1) * 1_000_000 - 2_500))  # a second of samples each
    submitted = 2 * MAX_PENDING_BYTES // len(chunk)
    assert 0 < file.dropped_chunks < submitted
    disk.released.set()
    deadline = time.monotonic() + 10.0
    while file.written_bytes < (submitted - file.dropped_chunks) * len(chunk) and time.monotonic() < deadline:
        time.sleep(0.01)  # the disk catches up
    file.submit(Chunk(b"after", 99_000_000, 99_000_000))
    file.close()
    assert file.join(10.0) and file.error is None
    content = disk.content
    assert content.endswith(b"after")
    dropout = ulog.dropout(file.dropped_chunks * 997_500 // 1000)  # the simulated ms of samples lost
    assert content[-len(b"after") - len(dropout) : -len(b"after")] == dropout


def test_a_log_file_that_cannot_be_written_keeps_the_error(tmp_path):
    class FullDisk(io.BytesIO):
        def write(self, data) -> int:
            raise OSError(28, "No space left on device")

    file = LogFile(tmp_path / "x.ulg", FullDisk())
    file.submit(Chunk(b"abc", 0, 0))
    file.close()
    assert file.join(10.0) and "No space left on device" in (file.error or "")


def test_logs_are_named_as_px4_names_them_and_listed_oldest_first(tmp_path):
    files = VehicleFiles.at(tmp_path)
    start = dt.datetime(2026, 5, 4, 10, 31, 2, tzinfo=dt.UTC)
    assert log_relative_path(start) == Path("log/2026-05-04/10_31_02.ulg")
    first = files.new_log_path(start)
    first.parent.mkdir(parents=True)
    first.write_bytes(b"1")
    second = files.new_log_path(start)  # the same second: a suffix
    assert second.name == "10_31_02_1.ulg"
    second.write_bytes(b"22")
    earlier = files.new_log_path(start - dt.timedelta(days=1))
    earlier.parent.mkdir()
    earlier.write_bytes(b"333")
    (first.parent / "notes.txt").write_text("not a log")
    (first.parent / "link.ulg").symlink_to(earlier)
    assert [(e.path.name, e.size) for e in files.logs()] == [("10_31_02.ulg", 3), ("10_31_02.ulg", 1),
                                                             ("10_31_02_1.ulg", 2)]  # fmt: skip
    assert files.logs()[0].path.parent.name == "2026-05-03"
    assert VehicleFiles.at(tmp_path / "none").logs() == []


def messages(link: QueueLink, kind: str) -> list:
    return [m for m in link.sent if m.get_type() == kind]


def test_a_listing_waits_for_a_log_just_ended_to_be_written(tmp_path):
    files = VehicleFiles.at(tmp_path)
    path = files.new_log_path(dt.datetime(2026, 1, 1, 12, 0, 0, tzinfo=dt.UTC))
    path.parent.mkdir(parents=True)
    path.write_bytes(b"")  # ended, its last chunk not yet on disk
    finishing = [True]
    service, link = LogDownloadService(files, system_id=1, finishing=lambda: finishing[0]), QueueLink()
    service.on_request_list(link, Request(start=0, end=0xFFFF))
    service.send()
    assert link.sent == []
    path.write_bytes(b"the whole log")
    finishing[0] = False
    service.send()
    assert [(m.id, m.size) for m in messages(link, "LOG_ENTRY")] == [(0, len(b"the whole log"))]


class Request:
    """A decoded LOG_* request as the services get it."""

    def __init__(self, **fields) -> None:
        self.target_system, self.target_component = 1, 1
        self.__dict__.update(fields)


def test_log_download_lists_sends_and_erases(tmp_path):
    files = VehicleFiles.at(tmp_path)
    service, link = LogDownloadService(files, system_id=1), QueueLink()
    service.on_request_list(link, Request(start=0, end=0xFFFF))
    assert [(m.num_logs, m.id) for m in messages(link, "LOG_ENTRY")] == [(0, 0)]  # no logs: num_logs 0
    contents = [bytes(range(256)) * 3, b"short"]
    for i, content in enumerate(contents):
        path = files.new_log_path(dt.datetime(2026, 1, 1, 12, 0, i, tzinfo=dt.UTC))
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content)
    link.sent.clear()
    service.on_request_list(link, Request(start=0, end=0xFFFF))
    service.send()
    assert [(m.id, m.num_logs, m.last_log_num, m.size) for m in messages(link, "LOG_ENTRY")] == [
        (0, 2, 1, len(contents[0])), (1, 2, 1, len(contents[1]))]  # fmt: skip
    link.sent.clear()
    service.on_request_data(link, Request(id=0, ofs=100, count=0xFFFFFFFF))
    for _ in range(5):
        service.send()
    data = messages(link, "LOG_DATA")
    assert b"".join(bytes(m.data[: m.count]) for m in data) == contents[0][100:]
    assert [m.ofs for m in data] == list(range(100, len(contents[0]), 90))
    link.sent.clear()
    service.on_request_data(link, Request(id=0, ofs=len(contents[0]), count=90))  # at the end: count 0
    assert [(m.ofs, m.count) for m in messages(link, "LOG_DATA")] == [(len(contents[0]), 0)]
    link.sent.clear()
    service.on_request_data(link, Request(id=7, ofs=0, count=90))  # not listed: ignored, as PX4
    service.on_request_list(link, Request(start=0, end=0xFFFF, target_system=9))  # another vehicle's
    service.send()
    assert link.sent == []
    service.on_erase(link, Request())
    assert files.logs() == [] and list(files.log_dir.iterdir()) == []
