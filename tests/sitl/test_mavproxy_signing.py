"""MAVLink 2 signing with MAVProxy, as a user sets it up (docs/mavlink.md, Signing): MAVProxy's `signing setup`
gives the vehicle its key over the GCS link; MAVProxy, signing, changes a parameter and the mode; an unsigned
pymavlink client on the API link is refused while the vehicle flies on for the keyed one."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from pymavlink import mavutil

from tiltrotor_sitl import Vehicle

M = mavutil.mavlink
MAVPROXY = shutil.which("mavproxy.py") or str(Path(sys.executable).parent / "mavproxy.py")
HOLD, LAND = (4, 3), (4, 6)  # PX4 (main, sub) modes


def main_sub(heartbeat) -> tuple[int, int]:
    return (heartbeat.custom_mode >> 16) & 0xFF, (heartbeat.custom_mode >> 24) & 0xFF


class MavProxy:
    """MAVProxy on the vehicle's GCS link, typed into as a user would."""

    def __init__(self, gcs_port: int, folder: Path) -> None:
        self.process = subprocess.Popen(
            [MAVPROXY, f"--master=udpin:127.0.0.1:{gcs_port}", "--target-system=1", f"--state-basedir={folder}",
             "--default-modules=link,signing,param,cmdlong,mode,log"],  # no ftp: parameters by PARAM_REQUEST_LIST either way
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=folder,
        )  # fmt: skip
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.append(line)

    def said(self, text: str) -> bool:
        return any(text in line for line in self.lines)

    def type(self, line: str) -> None:
        assert self.process.stdin is not None
        self.process.stdin.write(line + "\n")
        self.process.stdin.flush()

    def stop(self) -> None:
        if self.process.poll() is None:
            self.type("exit")
        try:
            self.process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self._reader.join(timeout=5)


def wait_for(predicate, what: str, timeout_s: float = 30.0, mavproxy: MavProxy | None = None) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        said = "" if mavproxy is None else "; MAVProxy said: " + "".join(mavproxy.lines[-30:])
        assert time.monotonic() < deadline, f"timed out waiting for {what}{said}"
        time.sleep(0.1)


@pytest.mark.skipif(not Path(MAVPROXY).exists(), reason="MAVProxy is installed with the test extra")
def test_mavproxy_sets_up_signing_and_flies_an_unsigned_client_is_refused(tmp_path):
    with Vehicle(controller="pid", spawn_alt=20.0, speed=1.0, truth=False, folder=tmp_path / "vehicle") as vehicle:
        mavproxy = MavProxy(vehicle.gcs_port, tmp_path)
        unsigned = None
        try:
            wait_for(lambda: mavproxy.said("Detected vehicle 1:1"), "MAVProxy to see the vehicle", 60, mavproxy)
            wait_for(lambda: mavproxy.said("Received "), "MAVProxy's parameter download", 60, mavproxy)
            mavproxy.type("signing setup correct horse battery staple")
            wait_for(lambda: "signing: key set" in vehicle.stderr(), "the vehicle's key", 30, mavproxy)
            mavproxy.type("param set MIS_TAKEOFF_ALT 12.5")
            wait_for(lambda: json.loads(vehicle.params_path.read_text()).get("parameters", {}).get("MIS_TAKEOFF_ALT")
                     == 12.5, "the signed PARAM_SET kept", 30, mavproxy)  # fmt: skip

            # (connected now: a socket nobody reads fills up, and the kernel drops what comes next)
            unsigned = mavutil.mavlink_connection(vehicle.mavsdk.replace("udpin://", "udpin:"), source_system=245)
            assert unsigned.wait_heartbeat(timeout=30) is not None
            unsigned.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            unsigned.mav.command_long_send(1, 1, M.MAV_CMD_DO_SET_MODE, 0, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, *LAND,
                                           0, 0, 0, 0)  # fmt: skip
            ack = unsigned.recv_match(type="COMMAND_ACK", blocking=True, timeout=10)
            assert ack is not None and ack.command == M.MAV_CMD_DO_SET_MODE and ack.result == M.MAV_RESULT_DENIED
            heartbeat = unsigned.recv_match(type="HEARTBEAT", blocking=True, timeout=10)
            assert heartbeat is not None and main_sub(heartbeat) == HOLD  # still flying for the keyed client

            mavproxy.type(f"long DO_SET_MODE {M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED} {LAND[0]} {LAND[1]}")
            deadline = time.monotonic() + 30
            mode = None
            while mode != LAND and time.monotonic() < deadline:
                heartbeat = unsigned.recv_match(type="HEARTBEAT", blocking=True, timeout=1)
                mode = None if heartbeat is None else main_sub(heartbeat)
            assert mode == LAND  # the signed command was obeyed (the unsigned client still sees the telemetry)
        finally:
            if unsigned is not None:
                unsigned.close()
            mavproxy.stop()
        assert mavproxy.said("Setup signing key"), "".join(mavproxy.lines[-40:])
