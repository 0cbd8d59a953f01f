"""Reboot (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN) as on hardware, through MAVSDK and pymavlink: the autopilot restarts
with its parameters applied, rejoins its plant, flies again, keeps its PID; armed, it is DENIED."""

from __future__ import annotations

import time

import psutil
import pytest

from tiltrotor_sitl import CommandRefused, Vehicle
from tiltrotor_sitl.ground_station import GroundLink
from transport.mavlink import mavlink as M

pytest.importorskip(
    "mavsdk", minversion="4", reason="MAVSDK-Python 4 (the native binding) is a test extra: pip install '.[test]'"
)

from mavsdk.plugins.action import Action  # noqa: E402
from mavsdk.plugins.param import Param  # noqa: E402

from tests.sitl.mavsdk_client import mavsdk_autopilot  # noqa: E402

NEW_SYSID = 7


def test_mavsdk_reboot_applies_mav_sys_id_and_the_new_process_flies(tmp_path):
    with Vehicle(speed=4.0, folder=tmp_path) as vehicle:
        pids = vehicle.pids
        with mavsdk_autopilot(vehicle.mavsdk) as system:
            Param(system).set_param_int("MAV_SYS_ID", NEW_SYSID)
            Action(system).reboot()
        link = GroundLink.listening(vehicle.gcs_port)
        try:
            station = link.station(NEW_SYSID)
            station.wait_connected(timeout_s=60.0)
            heartbeat = station.wait_message("HEARTBEAT", lambda m: m.system_status == M.MAV_STATE_STANDBY, 60.0)
            assert heartbeat is not None, "the rebooted vehicle is not ready"
            boot_ms = station.wait_message("ATTITUDE", timeout_s=10.0).time_boot_ms
            station.wait_message("SYS_STATUS", lambda m: m.onboard_control_sensors_health & M.MAV_SYS_STATUS_PREARM_CHECK,
                                 30.0)  # fmt: skip
            station.arm()
            station.takeoff(5.0)
            vehicle.truth.wait_until(lambda s: s.altitude > 4.5, timeout_sim_s=60)
        finally:
            link.close()
        assert vehicle.sysid == NEW_SYSID
        assert vehicle.pids == pids  # the same processes: the autopilot executed itself again
        assert "vtol-autopilot: rebooting" in vehicle.stderr()
        plant_time_s = vehicle.truth.latest().t
        print(f"rebooted: time_boot_ms {boot_ms} on the new process at plant time {plant_time_s:.1f} s")
        assert boot_ms / 1000 < plant_time_s - 1.0  # a new boot time: its clock started again
    assert not any(psutil.pid_exists(pid) and psutil.Process(pid).status() != psutil.STATUS_ZOMBIE for pid in pids)


def test_reboot_while_armed_is_denied_and_shutdown_as_px4_sitl(vehicle_factory):
    vehicle = vehicle_factory(speed=0)
    gcs = vehicle.ground_station
    for param1 in (2, 3):  # shutdown, bootloader: PX4's SITL denies both
        assert gcs.command(M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, param1).result == M.MAV_RESULT_DENIED
    gcs.arm()
    with pytest.raises(CommandRefused) as refused:
        gcs.command_accepted(M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1)
    assert refused.value.result == M.MAV_RESULT_DENIED and "disarm first" in str(refused.value)
    time.sleep(0.5)
    assert "rebooting" not in vehicle.stderr() and gcs.armed
