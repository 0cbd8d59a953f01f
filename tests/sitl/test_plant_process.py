"""`vtol-sim` as a process behind its UDP socket, driven by a small pymavlink peer (issue 2 "Done means")."""

from __future__ import annotations

import math
import os
import random
import time

import pytest

from aircraft.actuators import command_to_pwm
from sim_bridge.plant import hover_command
from tests.conftest import vtol_sim_command
from tiltrotor_sitl._children import run_to_end
from transport.geodesy import Home
from transport.mavlink import MAV_RESULT_ACCEPTED, MAV_RESULT_DENIED, MAV_RESULT_UNSUPPORTED, mavlink

G = 9.80665
HOME = Home()  # PX4 SITL's default


def fly(plant, pwm_for, steps: int, first=None):
    """Answer `steps` plant steps with pwm_for(sample); return the samples received (the first included)."""
    sample = first or plant.first_sample()
    samples = [sample]
    for _ in range(steps):
        plant.client.send_pwm(sample.time_usec, pwm_for(sample))
        sample = plant.client.receive_step(10.0)
        assert sample is not None, "the plant stopped answering"
        samples.append(sample)
    return samples


def hover_pwm(airframe):
    return command_to_pwm(airframe, hover_command(airframe))


def idle_pwm(airframe):
    command = hover_command(airframe)
    command[0:4] = 0.0
    return command_to_pwm(airframe, command)


def test_spawned_at_100m_with_rotors_stopped_it_falls_at_g(start_plant, airframe):
    plant = start_plant("--spawn-alt", "100", "--spawn-rotors", "stopped")
    samples = fly(plant, lambda s: idle_pwm(airframe), 200)
    last = samples[-1]
    assert last.time_usec == 500_000
    assert last.state.vz / 100 == pytest.approx(G * 0.5, abs=0.01)  # cm/s on the wire
    assert (HOME.alt + 100) - last.state.alt / 1000 == pytest.approx(0.5 * G * 0.25, abs=0.002)
    assert abs(last.sensor.zacc) < 1e-6  # free fall: the accelerometer reads zero
    assert plant.stop()["missed_commands"] == 0


def test_at_hover_trim_it_holds_within_a_tenth_of_a_metre_per_second(start_plant, airframe):
    plant = start_plant("--spawn-alt", "100")
    samples = fly(plant, lambda s: hover_pwm(airframe), 400)
    speeds = [max(abs(s.state.vx), abs(s.state.vy), abs(s.state.vz)) / 100 for s in samples]
    assert max(speeds) < 0.1
    assert samples[-1].sensor.zacc == pytest.approx(-G, abs=0.01)
    assert samples[-1].sensor.abs_pressure == pytest.approx(
        1013.25 * (1 - 2.25577e-5 * (HOME.alt + 100)) ** 5.25588, abs=0.01
    )


def test_on_the_ground_disarmed_it_stays_put(start_plant, airframe):
    plant = start_plant()
    samples = fly(plant, lambda s: [0] * 12, 400)  # PWM 0: nothing driven, as a disarmed autopilot
    first, last = samples[0].state, samples[-1].state
    assert (last.lat, last.lon) == (first.lat, first.lon)
    assert abs(last.alt - first.alt) <= 1  # mm
    assert last.vx == last.vy == last.vz == 0


def test_it_lifts_off_with_enough_thrust_and_lands_back_softly(start_plant, airframe):
    plant = start_plant()
    hover = hover_command(airframe)[0]
    phase = {"touchdown_speed": None, "airborne": False}

    def climb_then_descend(sample):
        t = sample.time_usec / 1e6
        vz = sample.state.vz / 100
        target = -1.0 if t < 3.0 else 0.5  # climb at 1 m/s for 3 s, then descend at 0.5 m/s
        height = sample.state.alt / 1000 - HOME.alt
        if height > 0.5:
            phase["airborne"] = True
        elif phase["airborne"] and phase["touchdown_speed"] is None and height < 0.26:
            phase["touchdown_speed"] = vz
        throttle = hover * (1 + 0.5 * (vz - target)) if phase["touchdown_speed"] is None else 0.0
        command = hover_command(airframe)
        command[0:4] = min(max(throttle, 0.0), 1.0)
        return command_to_pwm(airframe, command)

    samples = fly(plant, climb_then_descend, 400 * 12)
    heights = [s.state.alt / 1000 - HOME.alt for s in samples]
    assert max(heights) > 2.5
    assert phase["touchdown_speed"] is not None and 0 < phase["touchdown_speed"] < 1.0
    settled = samples[-400:]  # the last second: resting on its gear, no bounce
    assert all(abs(s.state.vz) <= 1 for s in settled)
    assert heights[-1] == pytest.approx(0.245, abs=0.01)


def test_lockstep_is_deterministic(start_plant, airframe):
    def commands(sample):
        t = sample.time_usec / 1e6
        command = hover_command(airframe)
        command[0:4] += 0.05 * math.sin(7 * t) * [1, -1, 1, -1][0]
        command[4:8] = math.radians(45 * t)
        command[8:12] = (math.sin(t), -math.sin(t), math.cos(t), 0.2)
        return command_to_pwm(airframe, command)

    runs = []
    for _ in range(2):
        plant = start_plant("--spawn-alt", "50")
        samples = fly(plant, commands, 800)
        runs.append([(s.state.get_msgbuf(), s.sensor.get_msgbuf()) for s in samples])
        plant.stop()
    assert runs[0] == runs[1]


def test_a_missing_command_times_out_holds_and_is_counted(start_plant, airframe):
    plant = start_plant("--spawn-alt", "100", "--lockstep-timeout", "0.05")
    sample = plant.first_sample()
    skipped = 0
    for k in range(60):
        if k % 20 == 10:
            skipped += 1  # say nothing: the plant must time out, hold the last command and step on
        else:
            plant.client.send_pwm(sample.time_usec, hover_pwm(airframe))
        sample = plant.client.receive_step(5.0)
        assert sample is not None
    assert sample.time_usec == 60 * 2500
    summary = plant.stop()
    assert summary["missed_commands"] == skipped == 3
    assert abs(sample.state.vz) <= 1  # held hover


def test_a_vanished_peer_pauses_the_plant_until_one_speaks_again(start_plant, airframe):
    plant = start_plant("--spawn-alt", "100", "--lockstep-timeout", "0.01", "--peer-lost-after", "4")
    sample = plant.first_sample()
    plant.client.send_pwm(sample.time_usec, hover_pwm(airframe))
    sample = plant.client.receive_step(5.0)
    stamps = []
    while (late := plant.client.receive_step(0.5)) is not None:  # we say nothing: 4 misses, then a pause
        stamps.append(late.time_usec)
    assert stamps == [5000, 7500, 10000]  # 2500, 5000, 7500 timed out and were stepped past; 10000 is the 4th
    assert plant.process.poll() is None  # paused, not gone
    plant.client.hello()  # an autopilot speaks: the plant resends the current state and steps on
    samples = fly(plant, lambda s: hover_pwm(airframe), 20, first=plant.client.receive_step(5.0))
    assert samples[0].time_usec == 10000 and samples[-1].time_usec == 10000 + 20 * 2500
    summary = plant.stop()
    assert summary["missed_commands"] == 4 and summary["peer_lost"] == 1


def acks(plant):
    return [m for m in plant.client.received_other if m.get_type() == "COMMAND_ACK"]


@pytest.mark.parametrize("sysid", [1, 4])
def test_failure_injection_over_the_link(start_plant, airframe, sysid):
    plant = start_plant("--spawn-alt", "100", "--sysid", str(sysid))
    sample = plant.first_sample()
    assert plant.client.plant_ids == (sysid, 200)  # from the handshake's CHALLENGE
    assert plant.client.command_plant(mavlink.MAV_CMD_INJECT_FAILURE, (101, 1, 1, float("nan")))
    samples = fly(plant, lambda s: hover_pwm(airframe), 80, first=sample)
    ack = acks(plant)[-1]
    assert (ack.command, ack.result) == (mavlink.MAV_CMD_INJECT_FAILURE, MAV_RESULT_ACCEPTED)
    texts = [m.text for m in plant.client.received_other if m.get_type() == "STATUSTEXT"]
    assert "plant: rotor 1: OFF" in texts
    # One rotor fewer: the vehicle accelerates down at about g/4 and rolls (rotor 1 is front right).
    assert samples[-1].sensor.zacc == pytest.approx(-0.75 * G, abs=0.3)
    assert samples[-1].state.rollspeed > 0.1
    plant.client.command_plant(mavlink.MAV_CMD_INJECT_FAILURE, (101, 0, 1, float("nan")))
    samples = fly(plant, lambda s: hover_pwm(airframe), 80, first=samples[-1])
    assert acks(plant)[-1].result == MAV_RESULT_ACCEPTED
    assert samples[-1].sensor.zacc == pytest.approx(-G, abs=0.3)
    plant.client.command_plant(mavlink.MAV_CMD_INJECT_FAILURE, (101, 1, 7, 0))
    plant.client.command_plant(mavlink.MAV_CMD_INJECT_FAILURE, (5, 1, 1, 0))
    plant.client.command_plant(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, (1,))
    other = 3 if sysid != 3 else 2  # a misaddressed command is refused aloud, not dropped
    plant.client.send_command_long(mavlink.MAV_CMD_INJECT_FAILURE, (101, 1, 1, float("nan")), (other, 200))
    plant.client.send_command_long(mavlink.MAV_CMD_INJECT_FAILURE, (101, 1, 1, float("nan")), (sysid, 1))
    samples = fly(plant, lambda s: hover_pwm(airframe), 4, first=samples[-1])
    assert [a.result for a in acks(plant)[-5:]] == [MAV_RESULT_DENIED, MAV_RESULT_UNSUPPORTED, MAV_RESULT_UNSUPPORTED,
                                                     MAV_RESULT_DENIED, MAV_RESULT_DENIED]  # fmt: skip
    texts = [m.text for m in plant.client.received_other if m.get_type() == "STATUSTEXT"]
    assert any(text.startswith(f"plant: command 420 for {other}/200 refused") for text in texts)
    assert samples[-1].sensor.zacc == pytest.approx(-G, abs=0.3)  # neither reached rotor 1
    summary = plant.stop()
    assert (summary["failures_applied"], summary["failures_rejected"]) == (2, 2)
    assert summary["misaddressed_commands"] == 2
    assert f"command 420 for {sysid}/1 refused: this plant is {sysid}/200" in plant.vehicle.stderr("vtol-sim")


def test_stuck_servo_over_the_link_seen_in_zenoh_truth(start_plant, airframe):
    import zenoh

    from transport.telemetry import decode_plant_states, plant_state_key
    from transport.zenoh_bus import session_config

    plant = start_plant("--spawn-alt", "100", "--sysid", "5", zenoh=True)
    received = []
    session = zenoh.open(session_config(listen=[], connect=[plant.zenoh_endpoint]))
    try:
        subscriber = session.declare_subscriber(plant_state_key(5), lambda s: received.append(bytes(s.payload)))
        sample = plant.first_sample()
        deadline = time.monotonic() + 20
        while not received and time.monotonic() < deadline:  # wait until the subscription is live
            sample = fly(plant, lambda s: hover_pwm(airframe), 1, first=sample)[-1]
        plant.client.command_plant(mavlink.MAV_CMD_INJECT_FAILURE, (102, 2, 1, 30.0))
        command = hover_command(airframe)
        command[4:8] = math.radians(80)
        end_s = fly(plant, lambda s: command_to_pwm(airframe, command), 800, first=sample)[-1].time_usec / 1e6
        # The truth up to the last step flown goes out as the plant waits for the next command: wait until it has
        # arrived, by its simulation time (a wall-clock guard only).
        deadline = time.monotonic() + 20
        while not received or decode_plant_states(received[-1])[-1]["t"] < end_s:
            assert time.monotonic() < deadline, f"no truth of the step at {end_s} s"
            time.sleep(0.01)
        subscriber.undeclare()
    finally:
        session.close()
    last = decode_plant_states(received[-1])[-1]
    assert last["t"] == pytest.approx(end_s)  # the last step flown, nothing after it
    assert math.degrees(last["tilt1"]) == pytest.approx(30.0, abs=1e-6)
    assert math.degrees(last["tilt2"]) == pytest.approx(80.0, abs=0.1)
    assert last["cmd_tilt1"] == pytest.approx(math.radians(80), abs=0.002)


def frames_of_bad_input(airframe, time_usec):
    """Random bytes, a truncated frame, a wrong CRC, an unknown message and out-of-range PWM."""
    link = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    good = mavlink.MAVLink_servo_output_raw_message(time_usec, 0, *([1500] * 16)).pack(link)
    wrong_crc = bytearray(good)
    wrong_crc[-1] ^= 0xFF
    unknown = bytearray(good)
    unknown[7:10] = (0x39, 0x30, 0x00)  # message id 12345
    rng = random.Random(7)
    return [
        bytes(rng.getrandbits(8) for _ in range(200)),
        good[: len(good) // 2],
        bytes(wrong_crc),
        bytes(unknown),
        b"",
        bytes([0xFD]) * 300,
    ]


def test_bad_input_does_not_crash_or_stall_the_plant(start_plant, airframe):
    plant = start_plant("--spawn-alt", "100")
    sample = plant.first_sample()
    for k in range(200):
        for junk in frames_of_bad_input(airframe, sample.time_usec):
            plant.client.send_raw(junk)
        pwm = hover_pwm(airframe)
        if k % 10 == 0:
            pwm[0], pwm[5] = 2500, 50  # out of range: clamped and counted
        plant.client.send_pwm(sample.time_usec, pwm)
        sample = plant.client.receive_step(5.0)
        assert sample is not None
    summary = plant.stop()
    assert summary["missed_commands"] == 0 and summary["commands_used"] == 200
    assert summary["pwm_clamped"] == 2 * 20
    dropped = summary["dropped"]
    assert dropped.get("bad_crc", 0) >= 200 and dropped.get("truncated", 0) >= 200
    assert sum(dropped.values()) >= 600
    assert plant.process.returncode == 0


@pytest.mark.parametrize(
    "args, expected",
    [
        (["--speed", "-2", "--realtime"], "--speed"),
        (["--instance", "x"], "--instance"),
        (["--spawn-alt", "nan"], "--spawn-alt"),
        (["--home", "1,2"], "--home"),
        (["--port", "70000"], "--port"),
        (["--bogus"], "unrecognized arguments"),
        (["--speed", "3"], "--speed only applies with --realtime"),
    ],
)
def test_bad_cli_arguments_give_one_line_and_exit_2(args, expected):
    result = run_to_end(vtol_sim_command(*args, "--no-zenoh"), timeout_s=60)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vtol-sim: error:") and expected in lines[0]


def test_help_works_through_the_console_script():
    script = os.path.join(os.path.dirname(os.sys.executable), "vtol-sim")
    result = run_to_end([script, "--help"], timeout_s=60)
    assert result.returncode == 0 and "--spawn-alt" in result.stdout


def test_free_running_mode_paces_itself_and_uses_the_latest_command(start_plant, airframe):
    plant = start_plant("--spawn-alt", "100", "--realtime", "--free-running", "--speed", "5", "--duration", "1")
    sample = plant.first_sample()
    plant.client.send_pwm(0, hover_pwm(airframe))  # any stamp: real time uses whatever came last
    times = [sample.time_usec]
    while (sample := plant.client.receive_step(5.0)) is not None:
        times.append(sample.time_usec)
    summary = plant.stop()
    assert times[-1] == 1_000_000 and summary["steps"] == 400 and summary["missed_commands"] == 0
    assert summary["commands_used"] == 1
    assert summary["real_time_factor"] < 6  # paced, not free-running (lockstep would be > 20x)


def test_paced_lockstep_waits_for_every_command_and_slows_down_when_the_autopilot_is_slow(start_plant, airframe):
    """--realtime keeps the lockstep: a step is integrated only with its own command, never faster than the wall
    clock times the speed; an autopilot that answers late slows the simulation down, which the plant says."""
    plant = start_plant("--spawn-alt", "100", "--realtime", "--speed", "5", "--duration", "3")
    sample = plant.first_sample()
    pwm = hover_pwm(airframe)
    texts, times, started = [], [], time.monotonic()
    while sample is not None:
        times.append(sample.time_usec)
        texts += [m.text for m in plant.client.received_other if m.get_type() == "STATUSTEXT"]
        plant.client.received_other.clear()
        if sample.time_usec >= 1_000_000:
            time.sleep(0.004)  # from 1 s on, 4 ms (wall) per step: the autopilot manages x0.6, not x5 (what is tested)
        plant.client.send_pwm(sample.time_usec, pwm)
        sample = plant.client.receive_step(5.0)
    wall = time.monotonic() - started
    texts += [m.text for m in plant.client.received_other if m.get_type() == "STATUSTEXT"]
    summary = plant.stop()
    assert times == [2500 * k for k in range(1201)]  # every step, in order, none skipped
    assert summary["commands_used"] == 1200 and summary["missed_commands"] == 0 and summary["stale_commands"] == 0
    assert summary["pacing"] == "paced" and summary["slowdowns"] >= 1
    # 1 s at x5, then as long as the autopilot needed: 4 ms per 2.5 ms step. The plant measures its speed over
    # 2 wall seconds (SPEED_WINDOW_S), so the flight lasts longer than that for the notice to be said.
    assert wall > 0.2 + 800 * 0.004
    assert any("slowed to" in text for text in texts)
