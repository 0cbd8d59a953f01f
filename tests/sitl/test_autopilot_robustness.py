"""vtol-autopilot against a fake plant the test controls: whatever the plant sends, the answers are valid PWM;
a silent plant is waited for; garbage is dropped and said (issue 3 "Done means")."""

from __future__ import annotations

import random
import socket
import time

import pytest

from tests.unit.test_autopilot_robustness import NAN
from tiltrotor_sitl import ProcessOptions, Vehicle
from tiltrotor_sitl._children import run_to_end
from tiltrotor_sitl._commands import AutopilotCommand
from transport.mavlink import Link
from transport.udp import receive


class FakePlant:
    """A UDP socket playing the plant: learns the autopilot from its HEARTBEAT, sends states, reads PWM."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.setblocking(False)
        self.port = self.sock.getsockname()[1]
        self.link = Link(1, 200)
        self.peer = None

    def wait_for_autopilot(self, timeout_s: float = 60.0) -> None:
        deadline = time.monotonic() + timeout_s
        while self.peer is None:
            assert time.monotonic() < deadline, "the autopilot never said hello"
            received = receive(self.sock, time.monotonic() + 0.2)
            if received is not None and self.link.parse(received[0]):
                self.peer = received[1]

    def send_state(self, time_usec: int, quaternion=(1.0, 0.0, 0.0, 0.0), rates=(0.0, 0.0, 0.0),
                   velocity_cm_s=(0, 0, 0), alt_mm=400_000, airspeed_cm_s=0) -> None:  # fmt: skip
        mav = self.link.mav
        state = mav.hil_state_quaternion_encode(
            time_usec, quaternion, *rates, 404433000, -799436000, alt_mm, *velocity_cm_s, airspeed_cm_s,
            airspeed_cm_s, 0, 0, -1000,
        )  # fmt: skip
        sensor = mav.hil_sensor_encode(time_usec, 0, 0, -9.8, 0, 0, 0, 0.2, 0, 0.4, 966.0, 0, 100, 14, 0x1FFF)
        self.sock.sendto(self.link.pack(state) + self.link.pack(sensor), self.peer)

    def send_raw(self, data: bytes) -> None:
        self.sock.sendto(data, self.peer)

    def read_pwm(self, timeout_s: float = 5.0):
        """The next SERVO_OUTPUT_RAW (time_usec, 12 channels), or None."""
        deadline = time.monotonic() + timeout_s
        while (received := receive(self.sock, deadline)) is not None:
            for message in self.link.parse(received[0]):
                if message.get_type() == "SERVO_OUTPUT_RAW":
                    channels = [getattr(message, f"servo{i}_raw") for i in range(1, 13)]
                    return message.time_usec, channels
        return None


@pytest.fixture
def autopilot_with_fake_plant(tmp_path):
    """The autopilot alone (tiltrotor_sitl.Vehicle with plant_port) flying the fake plant, which the test steps."""
    plant = FakePlant()
    autopilot = Vehicle(
        spawn_alt=100.0,
        truth=False,
        folder=tmp_path / "autopilot",
        processes=ProcessOptions(plant_port=plant.port, summary=True, wait_ready=False),
    ).start()
    try:
        plant.wait_for_autopilot()
        yield plant, autopilot
    finally:
        autopilot.stop()
        plant.sock.close()


def stop(autopilot: Vehicle) -> tuple[dict, str]:
    """SIGTERM the autopilot; its --summary counters and what it said on stderr."""
    autopilot.stop()
    return autopilot.summary(), autopilot.stderr()


ABSURD_STATES = [
    dict(quaternion=(NAN, 0.0, 0.0, 0.0)),  # dropped: not finite
    dict(rates=(float("inf"), 0.0, 0.0)),  # dropped
    dict(quaternion=(0.0, 0.0, 0.0, 0.0)),  # dropped: not a rotation
    dict(quaternion=(0.0, 1.0, 0.0, 0.0)),  # upside down
    dict(quaternion=(0.7071, 0.0, 0.7071, 0.0)),  # pitched up 90 deg (gimbal lock of the Euler angles)
    dict(rates=(50.0, -50.0, 50.0)),
    dict(velocity_cm_s=(32767, -32767, 32767), airspeed_cm_s=65535),
    dict(alt_mm=-2_000_000_000),
]


def test_pwm_is_always_valid_whatever_the_plant_says(autopilot_with_fake_plant):
    plant, autopilot = autopilot_with_fake_plant
    answered = 0
    for k in range(400):
        t = k * 2500
        state = ABSURD_STATES[k % len(ABSURD_STATES)] if 100 <= k < 300 else {}
        plant.send_state(t, **state)
        bad = state in ABSURD_STATES[:3]
        reply = plant.read_pwm(timeout_s=0.03 if bad else 5.0)
        if bad:
            assert reply is None  # no answer: the plant holds the last command
            continue
        assert reply is not None, f"no answer to step {k} ({state})"
        stamp, pwm = reply
        assert stamp == t
        assert all(1000 <= value <= 2000 for value in pwm), (state, pwm)
        answered += 1
    summary, _ = stop(autopilot)
    assert summary["invalid_states"] == 3 * 25 and answered == 400 - 75


def test_a_silent_plant_is_waited_for_and_the_flight_resumes(autopilot_with_fake_plant):
    plant, autopilot = autopilot_with_fake_plant
    for k in range(40):
        plant.send_state(k * 2500)
        assert plant.read_pwm() is not None
    time.sleep(2.5)  # the plant says nothing
    for k in range(40, 80):
        plant.send_state(k * 2500)
        reply = plant.read_pwm()
        assert reply is not None and reply[0] == k * 2500
    summary, errors = stop(autopilot)
    assert summary["plant_silences"] >= 1 and summary["steps"] == 80
    assert "the plant is silent; waiting for it" in errors


def test_garbage_from_the_plant_is_dropped_and_said(autopilot_with_fake_plant):
    plant, autopilot = autopilot_with_fake_plant
    rng = random.Random(3)
    good = plant.link.pack(plant.link.mav.heartbeat_encode(1, 12, 0, 0, 4))
    wrong_crc = bytearray(good)
    wrong_crc[-2] ^= 0x55
    for k in range(100):
        plant.send_raw(bytes(rng.getrandbits(8) for _ in range(64)))
        plant.send_raw(bytes(wrong_crc))
        plant.send_raw(good[:7])
        plant.send_state(k * 2500)
        reply = plant.read_pwm()
        assert reply is not None and reply[0] == k * 2500
    summary, errors = stop(autopilot)
    assert summary["steps"] == 100
    dropped = summary["dropped_from_plant"]
    assert dropped.get("bad_crc", 0) >= 100 and dropped.get("truncated", 0) >= 100
    assert "bad frame(s) from the plant" in errors


@pytest.mark.parametrize(
    "args, expected",
    [
        (["--controller", "lqr"], "--controller"),
        (["--mpc-horizon", "forever"], "--mpc-horizon"),
        (["--failure", "1,999,1,1"], "--failure"),
        (["--sim-port", "0"], "--sim-port"),
        (["--duration", "-1"], "--duration"),
    ],
)
def test_bad_autopilot_arguments_give_one_line_and_exit_2(args, expected):
    result = run_to_end(AutopilotCommand(extra=tuple(args)).argv(), timeout_s=60)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vtol-autopilot: error:") and expected in lines[0]
