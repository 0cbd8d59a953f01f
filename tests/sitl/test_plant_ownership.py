"""The plant belongs to one autopilot (issue 12 item 2): strays on the plant port change nothing and are counted."""

from __future__ import annotations

import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tiltrotor_sitl import ProcessOptions, Vehicle
from tiltrotor_sitl._free_ports import free_udp_port
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


def hellos_answered(port: int, count: int) -> int:
    """Send `count` HELLOs (an impostor autopilot's, from a port of its own) to the plant; how many it answered."""
    impostor = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    hello = b"".join(m.pack(impostor) for m in hello_messages(impostor, 99))
    answers = 0
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as other:
        other.bind((LOOPBACK, 0))
        other.settimeout(0.2)
        for _ in range(count):
            other.sendto(hello, (LOOPBACK, port))
            try:
                other.recvfrom(4096)
                answers += 1
            except TimeoutError:
                pass
    return answers


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


def forged_plant_states(k: int) -> list[tuple[str, bytes]]:
    """What a program pretending to be the plant would send the autopilot: the vehicle on the ground, upside down,
    stamped at the steps around k (the autopilot must believe only its plant's address)."""
    fake_plant = mavlink.MAVLink(None, srcSystem=1, srcComponent=mavlink.MAV_COMP_ID_AUTOPILOT1)
    state = b"".join(
        fake_plant.hil_state_quaternion_encode(2500 * (k * 8 + i), [0.0, 1.0, 0.0, 0.0], 0, 0, 0,
                                               473977420, 85455940, 488000, 0, 0, 0, 0, 0, 0, 0, 0)
        .pack(fake_plant)
        for i in range(8)
    )  # fmt: skip
    return [("state", state)]


def send_strays(port: int, stop: threading.Event, strays: Strays, forge=stray_datagrams) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        k = 0
        while not stop.wait(STRAY_PERIOD_S):
            for kind, data in forge(k):
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


@dataclass(frozen=True)
class Hover:
    """One paced hover's outcome."""

    down: np.ndarray
    plant: dict  # the plant's summary
    autopilot: dict  # the autopilot's summary
    strays: Strays


def hover(tmp_path: Path, name: str, strays_at: str | None = None) -> Hover:
    """A paced hover at 50 m for DURATION_S; strays from another socket during its middle second(s), sent to the
    plant's port (`strays_at` "plant") or to the autopilot's end of the plant link ("autopilot")."""
    log, bind = tmp_path / f"{name}.csv", free_udp_port()
    strays, stop = Strays(), threading.Event()
    with Vehicle(
        controller="pid",
        spawn_alt=50.0,
        speed=2.0,
        truth=False,
        folder=tmp_path / name,
        processes=ProcessOptions(
            duration_s=DURATION_S,
            summary=True,
            wait_ready=False,
            autopilot_args=("--profile", "hover", "--quiet", "--log", str(log), "--sim-bind-port", str(bind)),
        ),
    ) as vehicle:
        target, forge = (
            (bind, forged_plant_states) if strays_at == "autopilot" else (vehicle.ports.plant, stray_datagrams)
        )
        sender = threading.Thread(target=send_strays, args=(target, stop, strays, forge))
        try:
            if strays_at is not None:
                wait_for_log(log)  # the autopilot has the plant (a HELLO before that would be a candidate, answered)
                time.sleep(0.3)
                sender.start()
                time.sleep(1.0)
                stop.set()
                sender.join()
            vehicle.wait_finished(timeout_s=300)  # (an autopilot that exits with an error fails the test here)
        finally:
            stop.set()
    return Hover(
        read_flight_log(log).columns[DOWN], vehicle.summary("vtol-sim"), vehicle.summary("vtol-autopilot"), strays
    )


def max_deviation(down: np.ndarray, clean_down: np.ndarray) -> float:
    n = min(len(down), len(clean_down))
    assert n > 0.9 * DURATION_S * 100
    return float(np.max(np.abs(down[:n] - clean_down[:n])))


def test_strays_on_the_plant_port_change_nothing_and_are_counted(tmp_path):
    clean_run = hover(tmp_path, "clean")
    run = hover(tmp_path, "strays", strays_at="plant")
    clean_down, clean, down, summary, strays = clean_run.down, clean_run.plant, run.down, run.plant, run.strays
    assert strays.datagrams > 100
    foreign = summary["foreign"]
    assert foreign["datagrams"] == strays.datagrams
    assert foreign["HEARTBEAT"] == strays.heartbeats and foreign["PING"] == strays.datagrams // 4
    assert foreign["SERVO_OUTPUT_RAW"] == strays.servo_outputs and foreign["COMMAND_LONG"] == strays.commands
    assert summary["failures_applied"] == 0 and summary["handshakes"] == 1 and clean["handshakes"] == 1
    assert summary["missed_commands"] == clean["missed_commands"] == 0
    deviation = max_deviation(down, clean_down)
    print(f"strays: {strays}, max altitude deviation {deviation:.4f} m")
    assert deviation < 0.5


def test_forged_plant_states_sent_to_the_autopilot_change_nothing_and_are_counted(tmp_path):
    """The autopilot believes only its plant's address: upside-down states on the ground from another socket are
    ignored and counted (`foreign_on_plant_link` in its summary)."""
    clean_run = hover(tmp_path, "clean")
    run = hover(tmp_path, "forged", strays_at="autopilot")
    assert run.strays.datagrams > 50
    assert run.autopilot["foreign_on_plant_link"] == run.strays.datagrams
    assert clean_run.autopilot["foreign_on_plant_link"] == 0
    assert run.autopilot["invalid_states"] == 0 and run.autopilot["controllers_started"] == 1
    deviation = max_deviation(run.down, clean_run.down)
    print(f"forged states: {run.strays.datagrams} datagrams, max altitude deviation {deviation:.4f} m")
    assert deviation < 0.5


def test_a_named_autopilot_alone_gets_the_plant(tmp_path):
    """vtol-sim --autopilot-port P: a HELLO from any other port is never answered; the named one flies."""
    bind = free_udp_port()
    with Vehicle(
        spawn_alt=50.0,
        speed=None,
        truth=False,
        processes=ProcessOptions(
            autopilot=False, duration_s=1.0, summary=True, plant_args=("--autopilot-port", str(bind))
        ),
    ) as plant:  # started once it listens: the port is bound
        port = plant.ports.plant
        assert hellos_answered(port, 10) == 0
        with Vehicle(
            spawn_alt=50.0,
            truth=False,
            processes=ProcessOptions(
                plant_port=port,
                duration_s=1.0,
                wait_ready=False,
                autopilot_args=("--sim-bind-port", str(bind), "--profile", "hover", "--quiet"),
            ),
        ) as autopilot:
            autopilot.wait_finished(timeout_s=300)  # exit code 0, or VehicleError with its stderr
        plant.wait_finished(timeout_s=60)
        summary = plant.summary("vtol-sim")
    assert summary["handshakes"] == 1 and summary["foreign"]["datagrams"] == 10
    assert summary["peer"] == f"{LOOPBACK}:{bind}" and summary["steps"] == 400
