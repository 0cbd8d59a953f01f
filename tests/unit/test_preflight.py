"""The reboot's command line, the preflight commands' parameters, the calibration routines and the bind address,
without processes."""

from __future__ import annotations

import argparse

import pytest

from autopilot.commander.calibration import Calibration, Reading, Sensor, side_of
from autopilot.mavlink.preflight_commands import preflight_calibration, preflight_storage, reboot_shutdown
from autopilot.reboot import reboot_argv, started_sysid, without_options
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.requests import Calibrate, PreflightStorage, Reboot
from autopilot.topics.sensor_sample import SensorSample
from transport.cli import ipv4_address
from transport.mavlink import mavlink as M

NAN = float("nan")


def params(*values: float) -> tuple[float, ...]:
    return (*values, *[0.0] * (7 - len(values)))


def test_a_reboot_keeps_the_command_line_but_what_a_first_start_or_a_set_parameter_overrides():
    argv = ["--sysid", "3", "--controller=pid", "--spawn-alt", "10", "--params", "p.json", "--sim-bind-port", "9"]
    assert reboot_argv(argv, set(), 4242) == ["--sysid", "3", "--controller=pid", "--params", "p.json",
                                              "--sim-bind-port", "4242"]  # fmt: skip
    assert reboot_argv(argv, {"MAV_SYS_ID", "VT_CTRL", "MPC_XY_P"}, 1) == ["--params", "p.json", "--sim-bind-port", "1"]
    assert without_options(["--failure", "1,2,3,4", "--failure=5,6,7,8", "--quiet"], ["--failure"]) == ["--quiet"]


def test_the_start_line_names_the_system_id_launchers_follow():
    stderr = ("vtol-autopilot: mpc controller, plant link udp 127.0.0.1:1, system id 1, GCS ...\n"
              "vtol-autopilot: rebooting\nvtol-autopilot: mpc controller, plant link udp 127.0.0.1:1, system id 7, "
              "GCS ...\n")  # fmt: skip
    assert started_sysid(stderr) == 7
    assert started_sysid("") is None


def test_the_preflight_commands_parameters_as_px4_reads_them():
    assert reboot_shutdown(params(1)) == Reboot()
    assert reboot_shutdown(params(0)) == (M.MAV_RESULT_ACCEPTED, None)
    for action in (2, 3, 7, NAN):
        assert reboot_shutdown(params(action))[0] == M.MAV_RESULT_DENIED
    assert preflight_storage(params(2, -1)) == PreflightStorage(2)
    assert preflight_storage(params(5))[0] == M.MAV_RESULT_DENIED
    assert preflight_storage(params(NAN))[0] == M.MAV_RESULT_DENIED
    assert preflight_calibration(params(1)) == Calibrate("gyro")
    assert preflight_calibration(params(0, 1)) == Calibrate("mag")
    assert preflight_calibration(params(0, 0, 0, 0, 1)) == Calibrate("accel")
    assert preflight_calibration(params(0, 0, 0, 0, 2)) == Calibrate("level")
    assert preflight_calibration(params()) == Calibrate(None)
    for unsupported in (params(0, 0, 1), params(0, 0, 0, 1), params(0, 0, 0, 0, 4), params(0, 0, 0, 0, 0, 2),
                        params(0, 0, 0, 0, 0, 0, 1), params(3)):  # fmt: skip
        assert preflight_calibration(unsupported)[0] == M.MAV_RESULT_UNSUPPORTED
    assert preflight_calibration(params(NAN, NAN, NAN, NAN, NAN, NAN, NAN))[0] == M.MAV_RESULT_UNSUPPORTED


def sample(time_usec: int, gyro=(0.01, -0.02, 0.003), accel=(0.0, 0.0, -9.81), fields=0x1FFF) -> SensorSample:
    return SensorSample(time_usec, accel, gyro, (0.2, 0.0, 0.4), 1013.0, 0.0, 488.0, 15.0, fields)


def run(calibration: Calibration, seconds: float, **sample_args) -> None:
    for step in range(int(seconds * 400)):
        t = step * 2500
        calibration.step(Reading(sample(t, **sample_args), 0.01, -0.02, t))


def test_gyro_calibration_stores_the_mean_rate_as_offsets_with_px4s_texts():
    store, said = ParameterStore(None), []
    calibration = Calibration(store, lambda severity, text: said.append(text))
    assert calibration.start(Sensor.GYRO)[0] == M.MAV_RESULT_ACCEPTED
    assert calibration.start(Sensor.LEVEL)[0] == M.MAV_RESULT_TEMPORARILY_REJECTED
    run(calibration, 1.5)
    assert not calibration.running
    assert said[0] == "[cal] calibration started: 2 gyro" and said[-1] == "[cal] calibration done: gyro"
    assert "[cal] progress <50>" in said
    assert (store["CAL_GYRO0_XOFF"], store["CAL_GYRO0_YOFF"]) == pytest.approx((0.01, -0.02))


def test_a_failed_gyro_fails_the_calibration_and_the_level_one_stores_the_board_offsets():
    store, said = ParameterStore(None), []
    calibration = Calibration(store, lambda severity, text: said.append(text))
    calibration.start(Sensor.GYRO)
    run(calibration, 0.5, fields=0)
    assert said[-1] == "[cal] calibration failed: reading sensor" and store["CAL_GYRO0_XOFF"] == 0
    calibration.start(Sensor.LEVEL)
    run(calibration, 2.5)
    assert said[-1] == "[cal] calibration done: level"
    assert store["SENS_BOARD_X_OFF"] == pytest.approx(0.573, abs=0.01)  # 0.01 rad


def test_accel_calibration_on_a_vehicle_nobody_turns_fails_as_px4s_sitl():
    said: list[str] = []
    calibration = Calibration(ParameterStore(None), lambda severity, text: said.append(text))
    calibration.start(Sensor.ACCEL)
    run(calibration, 20.0)
    assert "[cal] down orientation detected" in said and "[cal] down side already completed" in said
    assert said[-1] == "[cal] calibration failed: timeout: no motion" and not calibration.running
    assert side_of((9.81, 0.0, 0.0)) == "back" and side_of((0.0, 0.0, 9.81)) == "up"


def test_a_cancel_stops_the_running_calibration():
    said: list[str] = []
    calibration = Calibration(ParameterStore(None), lambda severity, text: said.append(text))
    calibration.start(Sensor.MAG)
    assert calibration.cancel() == (M.MAV_RESULT_ACCEPTED, None)
    assert said[-1] == "[cal] calibration cancelled" and not calibration.running


def test_parameter_storage_resets_and_reloads(tmp_path):
    path = tmp_path / "params.json"
    store = ParameterStore(path)
    store.set("MPC_TKO_SPEED", 2.5)
    store.set("CAL_GYRO0_XOFF", 0.1)
    assert store.flush() is None
    assert store.reset(("CAL_GYRO",)) == ["CAL_GYRO0_XOFF"]
    assert store.reload() == ["CAL_GYRO0_XOFF"]  # the file still held it: read back
    assert store.reset() == ["MPC_TKO_SPEED", "CAL_GYRO0_XOFF"] and store.flush() is None
    assert '"parameters": {}' in path.read_text()


def test_the_bind_address_option_takes_ipv4_addresses_only():
    assert ipv4_address("127.0.0.2") == "127.0.0.2" and ipv4_address("0.0.0.0") == "0.0.0.0"
    for bad in ("300.1.1.1", "localhost", "::1", "", "1.2.3"):
        with pytest.raises(argparse.ArgumentTypeError, match="not an IPv4 address"):
            ipv4_address(bad)


def test_the_gcs_link_listens_on_loopback_unless_told_and_a_bad_address_is_refused():
    from autopilot.cli import build_parser
    from tiltrotor_sitl import Vehicle
    from tiltrotor_sitl._commands import AutopilotCommand

    assert build_parser().parse_args([]).gcs_bind == "127.0.0.1"
    assert build_parser().parse_args(["--gcs-bind", "0.0.0.0"]).gcs_bind == "0.0.0.0"
    assert "--gcs-bind" not in AutopilotCommand().argv()
    assert AutopilotCommand(gcs_bind="127.0.0.2").argv()[-2:] == ["--gcs-bind", "127.0.0.2"]
    with pytest.raises(ValueError, match="gcs_bind: not an IPv4 address"):
        Vehicle(gcs_bind="nowhere")
