"""The plant belongs to one autopilot (issue 12 item 2): strays on the plant port change nothing and are counted."""

from __future__ import annotations

import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ground_tools.processes import free_udp_port
from tiltrotor_sitl import Vehicle
from transport.flight_log import DOWN, read_flight_log
from transport.mavlink import mavlink
from transport.plant_handshake import hello_messages
from transport.ports import LOOPBACK

DURATION_S = 5.0
STRAY_PERIOD_S = 0.01


@dataclass
class Strays:
    """What the stray sender sent, per kind."""

    datagrams: int = 0
    heartbeats: int = 0
    servo_outputs: int = 0
    commands: int = 0


def stray_datagrams(k: int) -> list[tuple[str, bytes]]:
    """Every kind of stray: an autopilot's HELLO (a second autopilot), a ground station's HEARTBEAT, rotors-off
    SERVO_OUTPUT_RAW stamped for the steps around k, all-motors-off MAV_CMD_INJECT_FAILURE."""
    second_autopilot = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    gcs = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
    hello = b"".join(m.pack(second_autopilot) for m in hello_messages(second_autopilot, 12345))
    gcs_heartbeat = gcs.heartbeat_encode(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0).pack(gcs)
    rotors_off = b"".join(
        second_autopilot.servo_output_raw_encode((2500 * (k * 8 + i)) % (1 << 32), 0, *([1000] * 4 + [1500] * 12))
        .pack(second_autopilot)
        for i in range(8)
    )  # fmt: skip
    failure = gcs.command_long_encode(1, 200, mavlink.MAV_CMD_INJECT_FAILURE, 0, 101, 1, 0, 0, 0, 0, 0).pack(gcs)
    return [("hello", hello), ("heartbeat", gcs_heartbeat), ("servo", rotors_off), ("command", failure)]


def send_strays(port: int, stop: threading.Event, strays: Strays) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        k = 0
        while not stop.wait(STRAY_PERIOD_S):
            for kind, data in stray_datagrams(k):
                sock.sendto(data, (LOOPBACK, port))
                strays.datagrams += 1
                strays.heartbeats += kind in ("hello", "heartbeat")
                strays.servo_outputs += 8 * (kind == "servo")
                strays.commands += kind == "command"
            k += 1


def wait_for_log(log: Path, timeout_s: float = 120.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not (log.exists() and log.stat().st_size > 0):
        assert time.monotonic() < deadline, "the autopilot never started flying"
        time.sleep(0.02)


def hover(tmp_path: Path, name: str, with_strays: bool) -> tuple[np.ndarray, dict, Strays]:
    """A paced hover at 50 m for DURATION_S; strays from another socket during its middle second(s)."""
    log = tmp_path / f"{name}.csv"
    strays, stop = Strays(), threading.Event()
    with Vehicle(controller="pid", spawn_alt=50.0, speed=2.0, duration_s=DURATION_S, summary=True, truth=False,
                 wait_ready=False, autopilot_args=("--profile", "hover", "--quiet", "--log", str(log))) as vehicle:
        sender = threading.Thread(target=send_strays, args=(vehicle.ports.plant, stop, strays))
        try:
            if with_strays:
                wait_for_log(log)  # the autopilot has the plant (a HELLO before that would be a candidate, answered)
                time.sleep(0.3)
                sender.start()
                time.sleep(1.0)
                stop.set()
                sender.join()
            vehicle.wait_finished(timeout_s=300)  # (an autopilot that exits with an error fails the test here)
        finally:
            stop.set()
        summary = vehicle.summary("vtol-sim")
    return read_flight_log(log).columns[DOWN], summary, strays


def test_strays_on_the_plant_port_change_nothing_and_are_counted(tmp_path):
    clean_down, clean, _ = hover(tmp_path, "clean", with_strays=False)
    down, summary, strays = hover(tmp_path, "strays", with_strays=True)
    assert strays.datagrams > 100
    foreign = summary["foreign"]
    assert foreign["datagrams"] == strays.datagrams
    assert foreign["HEARTBEAT"] == strays.heartbeats and foreign["PING"] == strays.datagrams // 4
    assert foreign["SERVO_OUTPUT_RAW"] == strays.servo_outputs and foreign["COMMAND_LONG"] == strays.commands
    assert summary["failures_applied"] == 0 and summary["handshakes"] == 1 and clean["handshakes"] == 1
    assert summary["missed_commands"] == clean["missed_commands"] == 0
    n = min(len(down), len(clean_down))
    deviation = float(np.max(np.abs(down[:n] - clean_down[:n])))
    print(f"strays: {strays}, max altitude deviation {deviation:.4f} m")
    assert deviation < 0.5
    assert n > 0.9 * DURATION_S * 100


def test_a_named_autopilot_alone_gets_the_plant(tmp_path):
    """vtol-sim --autopilot-port P: a HELLO from any other port is never answered; the named one flies."""
    bind = free_udp_port()
    with Vehicle(autopilot=False, spawn_alt=50.0, speed=None, duration_s=1.0, summary=True, truth=False,
                 plant_args=("--autopilot-port", str(bind))) as plant:  # started once it listens: the port is bound
        port = plant.ports.plant
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as other:
            other.bind((LOOPBACK, 0))
            other.settimeout(0.2)
            impostor = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
            hello = b"".join(m.pack(impostor) for m in hello_messages(impostor, 7))
            answers = 0
            for _ in range(10):
                other.sendto(hello, (LOOPBACK, port))
                try:
                    other.recvfrom(4096)
                    answers += 1
                except TimeoutError:
                    pass
        assert answers == 0
        with Vehicle(plant_port=port, spawn_alt=50.0, duration_s=1.0, truth=False, wait_ready=False,
                     autopilot_args=("--sim-bind-port", str(bind), "--profile", "hover", "--quiet")) as autopilot:
            autopilot.wait_finished(timeout_s=300)  # exit code 0, or VehicleError with its stderr
        plant.wait_finished(timeout_s=60)
        summary = plant.summary("vtol-sim")
    assert summary["handshakes"] == 1 and summary["foreign"]["datagrams"] == 10
    assert summary["peer"] == f"{LOOPBACK}:{bind}" and summary["steps"] == 400
