"""The plant link signed with a shared key (docs/plant-link.md#signing): the keyed pair flies; an unkeyed or
wrongly keyed sender never gets the plant, even before its autopilot arrives; a bad key file is refused."""

from __future__ import annotations

import secrets
import signal
import time
from pathlib import Path

import pytest

from tests.sitl.test_plant_ownership import hellos_answered
from tiltrotor_sitl._children import Child, Stream, read_summary, run_to_end, start, stop
from tiltrotor_sitl._commands import AutopilotCommand, SimCommand, Zenoh, free_link_ports
from tiltrotor_sitl._free_ports import free_udp_port


def key_file(folder: Path, name: str) -> Path:
    path = folder / name
    path.write_text(secrets.token_hex(32) + "\n")
    return path


def start_plant(port: int, key: Path) -> Child:
    sim = SimCommand(port=port, spawn_alt=30.0, duration_s=2.0, summary=True, zenoh=Zenoh.off(), plant_signing_key=key)
    plant = start("vtol-sim", sim.argv(), stdout=Stream.CAPTURE, stderr=Stream.CAPTURE)
    assert "listening" in plant.stderr_line(timeout_s=60)
    return plant


def autopilot_command(port: int, key: Path | None) -> list[str]:
    return AutopilotCommand(sim_port=port, links=free_link_ports(), spawn_alt=30.0, profile="hover", duration_s=2.0,
                            controller="mpc", zenoh=Zenoh.off(), quiet=True, summary=True,
                            plant_signing_key=key).argv()  # fmt: skip


def test_the_keyed_autopilot_flies_and_unsigned_senders_never_get_the_plant(tmp_path):
    port, key = free_udp_port(), key_file(tmp_path, "plant.key")
    plant = start_plant(port, key)
    try:
        assert hellos_answered(port, 5) == 0  # before the autopilot: no candidate at all
        pilot = run_to_end(autopilot_command(port, key), timeout_s=300)
        plant.wait(60)
    finally:
        stop([plant], signal.SIGKILL)
    assert pilot.returncode == 0, pilot.stderr
    autopilot, summary = read_summary(pilot.stdout), plant.summary()
    assert autopilot["steps"] >= 790 and autopilot["dropped_from_plant"] == {}
    assert summary["handshakes"] == 1 and summary["missed_commands"] == 0
    assert summary["foreign"] == {"datagrams": 5}  # from another address, and not one message fit to read
    assert summary["dropped"]["bad_signature"] == 2 * 5  # HEARTBEAT + PING in each HELLO


@pytest.mark.parametrize("autopilot_key", [None, "other.key"])
def test_an_autopilot_without_the_key_never_gets_the_plant(tmp_path, autopilot_key):
    port = free_udp_port()
    plant = start_plant(port, key_file(tmp_path, "plant.key"))
    wrong = None if autopilot_key is None else key_file(tmp_path, autopilot_key)
    pilot = start("vtol-autopilot", autopilot_command(port, wrong), stdout=Stream.CAPTURE, stderr=Stream.CAPTURE)
    try:
        # Unanswered, it says HELLO every 20 ms in its first second, then every 0.25 s, and after 1 s without an answer
        # that the plant is silent: by then it has said HELLO 4 times or more. Wall time: a plant no autopilot has is not stepped, so no simulated time passes.
        deadline = time.monotonic() + 60
        while "the plant is silent" not in pilot.stderr_text():
            assert time.monotonic() < deadline and pilot.running(), pilot.stderr_text()
            time.sleep(0.05)
        assert "plant link udp" in pilot.stderr_text().splitlines()[0]  # started, saying HELLO
        assert pilot.poll() is None and plant.poll() is None
        for process in (pilot, plant):
            process.send_signal(signal.SIGTERM)
        pilot.wait(60)
        plant.wait(60)
    finally:
        stop([pilot, plant], signal.SIGKILL)
    autopilot, summary = pilot.summary(), plant.summary()
    assert summary["handshakes"] == 0 and summary["peer"] is None
    assert summary["dropped"]["bad_signature"] >= 2 * 4  # HEARTBEAT + PING in each HELLO
    assert autopilot["steps"] == 0


@pytest.mark.parametrize("program, content, reason", [
    ("sim_bridge", "zz" * 32, "not hexadecimal"),
    ("autopilot", None, "cannot be read"),
])  # fmt: skip
def test_a_bad_key_file_is_refused_with_one_line(tmp_path, program, content, reason):
    path = tmp_path / "plant.key"
    if content is not None:
        path.write_text(content)
    port = free_udp_port()
    builder = (
        SimCommand(port=port, zenoh=Zenoh.off(), plant_signing_key=path)
        if program == "sim_bridge"
        else AutopilotCommand(sim_port=port, links=free_link_ports(), zenoh=Zenoh.off(), plant_signing_key=path)
    )
    result = run_to_end(builder.argv(), timeout_s=60)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "--plant-signing-key" in lines[0] and reason in lines[0]
