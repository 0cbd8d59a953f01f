"""The vehicle's MAVLink interface against a hovering vehicle (docs/mavlink.md): identity, streams and their rates,
requests, offboard set-point checks, refused commands, failure injection (one vehicle shared by these tests, each
leaving it as it found it), and junk on both links (a vehicle of its own: it is stopped to read its counters)."""

from __future__ import annotations

import math
import random
import socket
import time
from pathlib import Path

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega

from aircraft.actuators import ROTORS, TILTS, pwm_to_command
from tests.sitl.ground_station import HOLD, OFFBOARD, VELOCITY_MASK
from tests.sitl.mavlink_sitl import start_sitl
from tiltrotor_sitl.ground_station import encode_parameter
from transport.mavlink import Link
from transport.mavlink import mavlink as M

NAN = math.nan
ALTITUDE = 50.0


def start_hovering(folder: Path):
    """Spawned hovering at 50 m in Hold (armed), plant in real time x4, a pymavlink ground station connected."""
    sitl = start_sitl(folder / "params.json", spawn_alt=ALTITUDE, speed=4.0, controller="pid")
    try:
        sitl.gs.connect()
    except BaseException:
        sitl.kill()
        raise
    return sitl


@pytest.fixture(scope="module")
def hovering(tmp_path_factory):
    """One hovering vehicle for the tests that leave it as they found it (hovering in Hold, streams and parameters
    at their defaults, no client on the API link)."""
    sitl = start_hovering(tmp_path_factory.mktemp("hover"))
    yield sitl
    sitl.kill()


@pytest.fixture
def own_hovering(tmp_path):
    """A hovering vehicle of its own, for a test that stops it or speaks on its API link."""
    sitl = start_hovering(tmp_path)
    yield sitl
    sitl.kill()


def rate_hz(gs, kind: str, seconds: float = 2.0) -> float:
    """Messages of `kind` per simulated second, by their own time_boot_ms, over about `seconds` of simulated time.

    The messages' own stamps, not the arrival of other messages, bound the window: a loaded machine delivers
    the streams in bursts, and a window edged by other messages' stamps counts a burst's extra ones.
    """
    with gs.recording(kind) as messages:
        gs.wait_sim(seconds)
    stamps = sorted(m.time_boot_ms for m in messages)
    if len(stamps) < 3 or stamps[-1] == stamps[0]:
        return len(stamps) / seconds
    return (len(stamps) - 1) * 1000.0 / (stamps[-1] - stamps[0])


def assert_hovering(gs, start=None):
    assert gs.armed and gs.mode == HOLD
    assert abs(gs.altitude - ALTITUDE) < 1.0
    assert all(abs(v) < 0.5 for v in gs.velocity)
    if start is not None:
        here = gs.latest["LOCAL_POSITION_NED"]
        assert math.hypot(here.x - start.x, here.y - start.y) < 1.0


def test_identity_streams_and_requests(hovering, airframe):
    gs = hovering.gs
    heartbeat = gs.latest["HEARTBEAT"]
    assert (heartbeat.type, heartbeat.autopilot) == (M.MAV_TYPE_VTOL_TILTROTOR, M.MAV_AUTOPILOT_PX4)
    assert heartbeat.get_srcSystem() == 1 and heartbeat.get_srcComponent() == 1
    assert heartbeat.base_mode & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED and gs.armed and gs.mode == HOLD
    assert heartbeat.system_status == M.MAV_STATE_ACTIVE
    gs.wait(lambda: {"EXTENDED_SYS_STATE", "HOME_POSITION", "GPS_RAW_INT", "BATTERY_STATUS", "VFR_HUD",
                     "SERVO_OUTPUT_RAW", "GLOBAL_POSITION_INT", "ATTITUDE_QUATERNION", "SYS_STATUS"} <= set(gs.latest),
            "every stream", timeout_s=20)  # fmt: skip
    ext = gs.latest["EXTENDED_SYS_STATE"]
    assert ext.vtol_state == M.MAV_VTOL_STATE_MC and ext.landed_state == M.MAV_LANDED_STATE_IN_AIR
    assert gs.latest["GLOBAL_POSITION_INT"].relative_alt == pytest.approx(ALTITUDE * 1000, abs=1000)
    # The outputs fly the hover: decoded as the plant decodes them, the four rotors, tilted up, carry the weight.
    servo = gs.latest["SERVO_OUTPUT_RAW"]
    decoded = pwm_to_command(airframe, [getattr(servo, f"servo{i}_raw") for i in range(1, 13)], np.zeros(12))
    thrusts, tilts = decoded.command[ROTORS] * airframe.thrust_max, decoded.command[TILTS]
    lift = float(np.sum(thrusts * np.cos(tilts)))
    print(f"hover outputs: thrusts {np.round(thrusts, 2)} N, tilts {np.round(np.degrees(tilts), 1)} deg, lift "
          f"{lift:.2f} N for a weight of {airframe.mass * airframe.gravity:.2f} N")  # fmt: skip
    assert (decoded.clamped, decoded.undriven) == (0, 0)
    assert np.all(np.abs(tilts) < math.radians(5.0))
    assert lift == pytest.approx(airframe.mass * airframe.gravity, rel=0.05)

    # Default rates, in simulated time; SET_MESSAGE_INTERVAL changes them, per link.
    assert rate_hz(gs, "ATTITUDE") == pytest.approx(50, abs=3)
    ack = gs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE, 100_000)
    assert ack.result == M.MAV_RESULT_ACCEPTED
    assert rate_hz(gs, "ATTITUDE") == pytest.approx(10, abs=1.5)
    assert gs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE, -1).result == M.MAV_RESULT_ACCEPTED
    assert rate_hz(gs, "ATTITUDE", 1.0) <= 1.0
    assert gs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE, 0).result == M.MAV_RESULT_ACCEPTED
    assert rate_hz(gs, "ATTITUDE", 1.0) == pytest.approx(50, abs=4)
    assert gs.command(M.MAV_CMD_GET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE).result == M.MAV_RESULT_ACCEPTED
    gs.wait(lambda: "MESSAGE_INTERVAL" in gs.latest, "MESSAGE_INTERVAL")
    assert gs.latest["MESSAGE_INTERVAL"].interval_us == 20_000

    # Requests: capabilities, home, missions (none), time sync.
    gs.latest.pop("AUTOPILOT_VERSION", None)
    ack = gs.command(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    assert ack.result == M.MAV_RESULT_ACCEPTED
    gs.wait(lambda: "AUTOPILOT_VERSION" in gs.latest, "AUTOPILOT_VERSION")
    capabilities = gs.latest["AUTOPILOT_VERSION"].capabilities
    assert capabilities & M.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
    assert capabilities & M.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    for mission_protocol in (
        M.MAV_PROTOCOL_CAPABILITY_MISSION_INT,
        M.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE,
        M.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY,
    ):
        assert capabilities & mission_protocol
    assert gs.command(M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1).result == M.MAV_RESULT_ACCEPTED
    # HOME_POSITION on request, its 0.5 Hz stream stopped first: what arrives is the answer, once.
    assert (
        gs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_HOME_POSITION, -1).result == M.MAV_RESULT_ACCEPTED
    )
    try:
        with gs.recording("HOME_POSITION") as homes:
            gs.wait_sim(3.0)  # more than the stream's 2 s period
            assert homes == []
            assert gs.command(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_HOME_POSITION).result == M.MAV_RESULT_ACCEPTED
            gs.wait(lambda: len(homes) > 0, "the requested HOME_POSITION")
            gs.wait_sim(3.0)
        assert len(homes) == 1
        home = homes[0]
        assert (home.latitude, home.longitude, home.altitude) == (473977420, 85455940, 488000)  # PX4 SITL's
    finally:  # the stream at its default rate again, for the tests that share this vehicle
        assert (
            gs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_HOME_POSITION, 0).result
            == M.MAV_RESULT_ACCEPTED
        )
    gs.conn.mav.mission_request_list_send(gs.vehicle, 1, M.MAV_MISSION_TYPE_MISSION)
    gs.wait(lambda: "MISSION_COUNT" in gs.latest, "MISSION_COUNT")
    assert gs.latest["MISSION_COUNT"].count == 0
    gs.conn.mav.timesync_send(0, 12345)
    gs.wait(lambda: "TIMESYNC" in gs.latest and gs.latest["TIMESYNC"].ts1 == 12345, "TIMESYNC")
    assert gs.latest["TIMESYNC"].tc1 > 0


def test_streams_idle_until_a_client_speaks_on_a_link(hovering):
    """The API link sends to 127.0.0.1:api_remote; nobody has spoken there yet: at most 2 Hz per stream."""
    gs = hovering.gs
    listener = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    listener.bind(("127.0.0.1", hovering.ports["api_remote"]))
    listener.setblocking(False)
    link = Link(255, 190)
    try:

        def count_attitude(seconds: float) -> float:
            stamps = []
            until = gs.sim_time + seconds
            while gs.sim_time < until:
                gs.pump(0.005)
                while True:
                    try:
                        data = listener.recv(65536)
                    except BlockingIOError:
                        break
                    stamps += [m.time_boot_ms for m in link.parse(data) if m.get_type() == "ATTITUDE"]
            return len(stamps) / seconds

        assert count_attitude(3.0) <= 2.5
        listener.sendto(link.pack(link.mav.heartbeat_encode(M.MAV_TYPE_GCS, 8, 0, 0, 0)),
                        ("127.0.0.1", hovering.ports["api"]))  # fmt: skip
        assert count_attitude(2.0) == pytest.approx(50, abs=5)
    finally:
        listener.close()


REFUSED = [
    # (what, command, params, result, STATUSTEXT fragment or None)
    ("arm with param1 5", M.MAV_CMD_COMPONENT_ARM_DISARM, (5,), M.MAV_RESULT_DENIED, "param1 must be 1 or 0"),
    ("disarm in the air", M.MAV_CMD_COMPONENT_ARM_DISARM, (0,), M.MAV_RESULT_DENIED, "in the air"),
    ("takeoff to 1e9 m", M.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, NAN, NAN, NAN, 1e9), M.MAV_RESULT_DENIED, "Takeoff denied"),
    ("takeoff to inf", M.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, NAN, NAN, NAN, math.inf), M.MAV_RESULT_DENIED, "infinite"),
    ("mode 99", M.MAV_CMD_DO_SET_MODE, (1, 99, 0), M.MAV_RESULT_DENIED, "not supported"),
    ("mode STABILIZED", M.MAV_CMD_DO_SET_MODE, (1, 7, 0), M.MAV_RESULT_DENIED, "STABILIZED not supported"),
    ("POSCTL without manual control", M.MAV_CMD_DO_SET_MODE, (1, 3, 0), M.MAV_RESULT_TEMPORARILY_REJECTED,
     "no manual control"),
    ("change speed to NaN", M.MAV_CMD_DO_CHANGE_SPEED, (1, NAN), M.MAV_RESULT_DENIED, "not finite"),
    ("mode without custom flag", M.MAV_CMD_DO_SET_MODE, (0, 4, 3), M.MAV_RESULT_DENIED, "custom modes"),
    ("mode NaN", M.MAV_CMD_DO_SET_MODE, (1, NAN, 0), M.MAV_RESULT_DENIED, "integers"),
    ("offboard without set-points", M.MAV_CMD_DO_SET_MODE, (1, 6, 0), M.MAV_RESULT_TEMPORARILY_REJECTED,
     "Offboard denied"),
    ("interval NaN", M.MAV_CMD_SET_MESSAGE_INTERVAL, (30, NAN), M.MAV_RESULT_DENIED, "Message interval"),
    ("interval of a non-stream", M.MAV_CMD_SET_MESSAGE_INTERVAL, (9999, 1000), M.MAV_RESULT_DENIED, "not a stream"),
    ("request message 9999", M.MAV_CMD_REQUEST_MESSAGE, (9999,), M.MAV_RESULT_DENIED, "not available"),
    ("transition to state 7", M.MAV_CMD_DO_VTOL_TRANSITION, (7,), M.MAV_RESULT_DENIED, "Transition denied"),
    ("injection while disabled", M.MAV_CMD_INJECT_FAILURE, (102, 2, 1, 60), M.MAV_RESULT_DENIED, "SYS_FAILURE_EN"),
    ("an unknown command", 31337, (1, 2, 3), M.MAV_RESULT_UNSUPPORTED, None),
    ("a command PX4 has but we do not", M.MAV_CMD_DO_GRIPPER, (1, 0), M.MAV_RESULT_UNSUPPORTED, None),
    ("an ROI mode beyond MAV_ROI", M.MAV_CMD_DO_SET_ROI, (7,), M.MAV_RESULT_DENIED, "ROI denied"),
    ("an ROI at NaN", M.MAV_CMD_DO_SET_ROI_LOCATION, (0, 0, 0, 0, math.nan, 8.5, 0), M.MAV_RESULT_DENIED, "ROI denied"),
    ("go-to into the ground", M.MAV_CMD_DO_REPOSITION, (-1, 0, 0, 0, 0, 0, 0), M.MAV_RESULT_DENIED, "above home"),
]  # fmt: skip


def test_commands_with_bad_parameters_are_refused_with_a_reason(hovering):
    gs = hovering.gs
    start = gs.latest["LOCAL_POSITION_NED"]
    for what, command, params, result, fragment in REFUSED:
        texts = len(gs.statustexts)
        ack = gs.command(command, *params)
        assert ack.result == result, what
        assert ack.get_srcSystem() == 1 and ack.get_srcComponent() == 1
        assert (ack.target_system, ack.target_component) == (255, 190)
        if fragment is not None:
            gs.wait(lambda: any(fragment in t for t in gs.statustexts[texts:]), f"STATUSTEXT for {what}")
    # A command for another system is not ours: no answer at all.
    count = len(gs.acks)
    gs.conn.mav.command_long_send(42, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0)
    gs.wait_sim(0.5)
    assert len(gs.acks) == count
    assert_hovering(gs, start)


def set_int_parameter(gs, name: str, integer: int) -> None:
    value = encode_parameter(integer, M.MAV_PARAM_TYPE_INT32)
    assert gs.param_set(name, value, M.MAV_PARAM_TYPE_INT32).param_value == value


def set_failure_enabled(gs, enabled: int) -> None:
    set_int_parameter(gs, "SYS_FAILURE_EN", enabled)


def test_failure_injection_is_gated_forwarded_acknowledged_and_announced(hovering):
    gs = hovering.gs
    set_failure_enabled(gs, 1)
    try:
        texts = len(gs.statustexts)
        assert gs.command(M.MAV_CMD_INJECT_FAILURE, 102, 2, 1, 30.0).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: "Failure injected: servo 1 STUCK at 30 deg" in gs.statustexts[texts:], "the announcement")
        gs.wait(lambda: any("plant: tilt servo 1: STUCK at 30" in t for t in gs.statustexts[texts:]), "the plant's")
        gs.wait_sim(2.0)
        assert abs(gs.altitude - ALTITUDE) < 2.0  # still flying (the controller knows the servo is stuck)
        for what, params, result in [
            ("unit 103", (103, 1, 1), M.MAV_RESULT_UNSUPPORTED),
            ("type GARBAGE", (101, 3, 1), M.MAV_RESULT_UNSUPPORTED),
            ("servo 9", (102, 1, 9), M.MAV_RESULT_DENIED),
            ("motor 1.5", (101, 1, 1.5), M.MAV_RESULT_DENIED),
            ("param4 inf", (102, 2, 1, math.inf), M.MAV_RESULT_DENIED),
            ("servo stuck at 500 deg (the plant refuses)", (102, 2, 2, 500.0), M.MAV_RESULT_DENIED),
        ]:
            assert gs.command(M.MAV_CMD_INJECT_FAILURE, *params).result == result, what
        assert any("plant: failure refused" in t for t in gs.statustexts[texts:])
        # Cleared (type OK), and with the controllers told by the injection (the paper's known failures), a delay
        # before they learn of it (SYS_FAILURE_DLY).
        texts = len(gs.statustexts)
        assert gs.command(M.MAV_CMD_INJECT_FAILURE, 102, 0, 1).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: "Failure injected: servo 1 OK (cleared)" in gs.statustexts[texts:], "the clearing")
        set_int_parameter(gs, "VT_FAIL_ORACLE", 1)
        assert gs.param_set("SYS_FAILURE_DLY", 0.5, M.MAV_PARAM_TYPE_REAL32).param_value == 0.5
        assert gs.command(M.MAV_CMD_INJECT_FAILURE, 101, 4, 2, 0.8).result == M.MAV_RESULT_ACCEPTED
        gs.wait(lambda: any("motor 2 WRONG x0.8, controllers told in 0.5 s" in t for t in gs.statustexts), "delay")
        assert gs.command(M.MAV_CMD_INJECT_FAILURE, 101, 0, 0).result == M.MAV_RESULT_ACCEPTED
        assert gs.param_set("SYS_FAILURE_DLY", 0.0, M.MAV_PARAM_TYPE_REAL32).param_value == 0.0
        set_int_parameter(gs, "VT_FAIL_ORACLE", 0)
        gs.wait_sim(2.0)
        gs.wait(lambda: all(abs(v) < 0.5 for v in gs.velocity), "the hover to settle", timeout_s=20)
        assert_hovering(gs)
    finally:
        set_failure_enabled(gs, 0)


def test_offboard_set_point_checks_and_frames(hovering):
    gs = hovering.gs
    mav = gs.conn.mav
    texts = len(gs.statustexts)
    mav.set_position_target_local_ned_send(0, gs.vehicle, 1, M.MAV_FRAME_LOCAL_NED, VELOCITY_MASK, 0, 0, 0, NAN, 0, 0, 0, 0, 0,
                                           0, 0)  # fmt: skip
    mav.set_position_target_local_ned_send(0, gs.vehicle, 1, M.MAV_FRAME_LOCAL_NED, VELOCITY_MASK, 0, 0, 0, math.inf, 0, 0, 0, 0,
                                           0, 0, 0)  # fmt: skip
    mav.set_position_target_local_ned_send(
        0, gs.vehicle, 1, M.MAV_FRAME_LOCAL_NED, 0b110000111111, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0
    )  # fmt: skip  (an acceleration set-point)
    mav.set_position_target_local_ned_send(0, gs.vehicle, 1, 99, VELOCITY_MASK, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0)
    gs.wait(lambda: sum("Set-point dropped" in t for t in gs.statustexts[texts:]) >= 3, "the drops")
    assert gs.set_mode(OFFBOARD).result == M.MAV_RESULT_TEMPORARILY_REJECTED  # nothing valid received
    mav.set_position_target_local_ned_send(0, gs.vehicle, 1, M.MAV_FRAME_LOCAL_NED, VELOCITY_MASK, 0, 0, 0, 1e6, -1e6, 1e6, 0, 0,
                                           0, 0, 0)  # fmt: skip
    gs.wait(lambda: any("clamped" in t for t in gs.statustexts[texts:]), "the clamp notice")
    gs.wait_sim(1.5)  # let that (clamped) set-point go stale

    # Body frame: 2 m/s forward is north at yaw 0; then global-frame velocity 2 m/s east.
    def body() -> None:
        mav.set_position_target_local_ned_send(gs.time_boot_ms, gs.vehicle, 1, M.MAV_FRAME_BODY_NED, VELOCITY_MASK, 0, 0, 0,
                                               2.0, 0, 0, 0, 0, 0, 0, 0)  # fmt: skip

    body()
    gs.pump(0.02)
    assert gs.set_mode(OFFBOARD).result == M.MAV_RESULT_ACCEPTED
    gs.wait_sim(3.0, every=body)
    yaw = gs.latest["ATTITUDE"].yaw
    assert gs.velocity[0] == pytest.approx(2.0 * math.cos(yaw), abs=0.3)

    def east() -> None:
        mav.set_position_target_global_int_send(gs.time_boot_ms, gs.vehicle, 1, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                                                VELOCITY_MASK, 0, 0, 0, 0, 2.0, 0, 0, 0, 0, 0, 0)  # fmt: skip

    gs.wait_sim(3.0, every=east)
    assert gs.velocity[1] == pytest.approx(2.0, abs=0.3) and abs(gs.velocity[0]) < 0.3
    assert gs.set_mode(HOLD).result == M.MAV_RESULT_ACCEPTED
    gs.wait(lambda: all(abs(v) < 0.3 for v in gs.velocity), "Hold to stop", timeout_s=30)
    assert_hovering(gs)


def kernel_drops(port: int) -> int:
    """Datagrams the kernel dropped for the UDP socket bound to 127.0.0.1:port (its receive buffer full), from
    /proc/net/udp; 0 where there is no such table."""
    try:
        rows = Path("/proc/net/udp").read_text().splitlines()[1:]
    except OSError:
        return 0
    for row in rows:
        fields = row.split()
        if fields[1] == f"0100007F:{port:04X}":
            return int(fields[-1])
    return 0


def test_junk_on_both_links_is_dropped_while_the_vehicle_hovers(own_hovering):
    hovering = own_hovering  # it speaks on the API link and stops the vehicle to read its counters
    gs = hovering.gs
    start = gs.latest["LOCAL_POSITION_NED"]
    rng = random.Random(11)
    junk = Link(255, 190)
    good = junk.pack(junk.mav.heartbeat_encode(M.MAV_TYPE_GCS, 8, 0, 0, 0))
    wrong_crc = bytearray(good)
    wrong_crc[-1] ^= 0x5A
    other = ardupilotmega.MAVLink(None, 255, 190)
    unknown = other.wind_encode(10.0, 5.0, 0.0).pack(other)  # an ArduPilot-only message: unknown to `common`
    arm_junk = junk.pack(junk.mav.command_long_encode(1, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0, NAN, NAN, 0, 0, 0, 0, 0))
    absurd = junk.pack(
        junk.mav.set_position_target_local_ned_encode(
            0, 1, 1, M.MAV_FRAME_LOCAL_NED, VELOCITY_MASK, 0, 0, 0, NAN, math.inf, -math.inf, 0, 0, 0, 0, 0
        )
    )
    param_junk = junk.pack(junk.mav.param_set_encode(1, 1, bytes(rng.getrandbits(8) | 1 for _ in range(16)), NAN, 77))
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    targets = [("127.0.0.1", hovering.ports["gcs"]), ("127.0.0.1", hovering.ports["api"])]
    drops_before = {name: kernel_drops(hovering.ports[name]) for name in ("gcs", "api")}
    try:
        deadline = gs.sim_time + 6.0
        wall_deadline = time.monotonic() + 60
        rounds = 0
        while gs.sim_time < deadline:
            assert time.monotonic() < wall_deadline, "telemetry stopped during the junk"
            for target in targets:
                for datagram in (bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 300))), bytes(wrong_crc),
                                 good[: rng.randint(1, len(good) - 1)], unknown, arm_junk, absurd, param_junk,
                                 good + bytes(rng.getrandbits(8) for _ in range(40)), bytes(60000)):  # fmt: skip
                    sender.sendto(datagram, target)
            rounds += 1
            gs.pump(0.01)
        assert rounds > 20
    finally:
        sender.close()
    gs.wait_sim(1.0)
    assert_hovering(gs, start)
    dropped_by_kernel = {name: kernel_drops(hovering.ports[name]) - drops_before[name] for name in ("gcs", "api")}
    autopilot, plant = hovering.stop()
    assert hovering.autopilot.returncode == 0
    for name in ("gcs", "api"):
        link = autopilot["links"][name]
        # Every round's junk reaches the autopilot unless the kernel dropped it from the full socket buffer (a
        # loaded machine, the 60 kB datagrams filling it): each datagram dropped takes at most one of each kind.
        least = max(1, rounds - dropped_by_kernel[name])
        assert link["dropped"].get("bad_crc", 0) >= least and link["dropped"].get("truncated", 0) >= least
        assert link["dropped"].get("unknown_message", 0) >= least
        # One 60 kB datagram per round and port: a socket buffer holds ~3, so on a loaded machine the kernel drops
        # some before the autopilot can count them; each one it receives is counted, none is more than was sent.
        assert 0 < link["dropped"].get("oversized_datagram", 0) <= rounds
    # Two NaN set-points per round (one per port); on a loaded machine the kernel drops a few of those datagrams
    # behind the 60 kB ones before they are read, as above.
    assert autopilot["links"]["setpoints_dropped"] >= 1.5 * rounds
    assert autopilot["armed"] and autopilot["flight_mode"] == "Hold"
    assert plant["missed_commands"] == 0
    errors = hovering.stderr()
    assert "not handled" not in errors and "Traceback" not in errors
