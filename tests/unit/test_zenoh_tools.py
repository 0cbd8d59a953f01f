"""`vtol record` and `vtol watch`: the pure data handling without zenoh, the recorder against an in-process
publisher on loopback, and both commands against a real plant and autopilot (killed by PID at the end)."""

from __future__ import annotations

import json
import math
import re
import time
from collections import deque

import numpy as np
import pytest

from aircraft.airframe import load_airframe
from autopilot.controllers import build_flight_controller
from autopilot.logger.control_telemetry import BATCH_SAMPLES, ControlTelemetry
from ground_tools import cli
from ground_tools.telemetry_record import (
    decode_samples,
    encode_records,
    endpoints_from_args,
    key_expression,
    read_recording,
    short_error,
)
from ground_tools.telemetry_view import TelemetryView, euler_deg, push, status_line, time_series
from ground_tools.watch import has_display, new_events, run_window
from ground_tools.watch_figure import build_figure, draw, save_snapshot
from transport.telemetry import (
    PLANT_STATE_BYTES,
    PLANT_STATE_FIELDS,
    PlantStateBatch,
    control_key,
    decode_plant_states,
    encode_control,
    encode_plant_state,
    mpc_key,
    plant_state_key,  # fmt: skip
)


def plant_payload(t: float = 1.0, down: float = -100.0, vn: float = 0.0, q=(1.0, 0.0, 0.0, 0.0)) -> bytes:
    values = dict.fromkeys(PLANT_STATE_FIELDS, 0.0)
    values.update(t=t, down=down, vn=vn, qw=q[0], qx=q[1], qy=q[2], qz=q[3], tilt1=math.radians(30), cmd_thrust1=0.7)
    return np.array([values[f] for f in PLANT_STATE_FIELDS], dtype="<f8").tobytes()


def control_payload(t: float = 1.0, mode: str = "MC") -> bytes:
    z4 = np.zeros(4)
    return encode_control(t, mode, np.array([5.0, 0.0, -1.0]), np.array([0.0, math.radians(-10), 0.0]), z4,
                          np.zeros(8), np.zeros(6), np.zeros(6))  # fmt: skip


def mpc_payload(t: float = 1.0, n: int = 26) -> bytes:
    return json.dumps(
        {
            "t": t,
            "ok": True,
            "status": "solved",
            "solve_time_ms": 2.5,
            "qp_iterations": 7,
            "cost": 1.0,
            "predicted_velocity": [[0.1 * k, 0.0, 0.0] for k in range(n)],
            "predicted_tilt": [[0.0] * 4] * n,
            "thrust": [9.0] * 4,
            "attitude_sp": [0.0] * 3,
        }
    ).encode()


# ---- pure functions ------------------------------------------------------------------------------------------------
def test_decode_samples_and_records():
    [state] = decode_samples(plant_state_key(1), plant_payload(down=-100.0))
    assert state["down"] == -100.0 and len(state) == 43
    assert decode_samples(control_key(1), control_payload())[0]["mode"] == "MC"
    lines, ok = encode_records(plant_state_key(3), b"\x00" * 24)
    assert not ok and [json.loads(line) for line in lines] == [
        {"key": "vtol/3/plant/state", "bytes": 24,
         "error": "plant state payload has 24 bytes, expected a multiple of 344"}]  # fmt: skip
    for junk, reason in ((b"\xff\xfe", "not UTF-8"), (b"{nope", "not JSON")):
        lines, ok = encode_records("vtol/1/autopilot/events", junk)
        assert not ok and json.loads(lines[0])["error"].startswith(reason)
    lines, ok = encode_records(plant_state_key(1), plant_payload())
    assert ok and json.loads(lines[0])["payload"]["tilt1"] == pytest.approx(math.radians(30))
    # Python's json writes NaN; orjson does not read it, the recorder still does
    lines, ok = encode_records("vtol/2/autopilot/events", b'{"t": NaN, "text": "x"}')
    assert ok and math.isnan(json.loads(lines[0])["payload"]["t"])
    # the autopilot's own payloads carry a non-finite number as null; the view plots it as a gap
    nan_control = encode_control(1.0, "MC", np.array([np.nan, 0.0, 0.0]), np.zeros(3), np.zeros(4), np.zeros(8),
                                 np.zeros(6), np.zeros(6))  # fmt: skip
    assert b'"velocity_sp":[null,0.0,0.0]' in nan_control
    view = TelemetryView()
    view.add(control_key(1), nan_control)
    assert not view.errors and math.isnan(view.last_control["vn_sp"])


class RecordingPublisher:
    """A zenoh publisher's stand-in: keeps what is put."""

    def __init__(self, key: str) -> None:
        self.key, self.payloads = key, []

    def put(self, payload: bytes) -> None:
        self.payloads.append(payload)


class RecordingSession:
    def __init__(self) -> None:
        self.publishers: dict[str, RecordingPublisher] = {}

    def declare_publisher(self, key: str) -> RecordingPublisher:
        return self.publishers.setdefault(key, RecordingPublisher(key))


def test_autopilot_samples_are_gathered_in_lockstep_and_put_at_once_otherwise():
    session = RecordingSession()
    telemetry = ControlTelemetry(session, 1)
    controller = build_flight_controller(load_airframe(), "pid")
    control = session.publishers[control_key(1)]
    for k in range(BATCH_SAMPLES - 1):
        telemetry.publish(0.01 * k, controller, gather=True)
    assert control.payloads == []
    telemetry.publish(0.09, controller, gather=True)  # the tenth: the batch goes out
    telemetry.publish(0.10, controller, gather=True)
    telemetry.publish(0.11, controller, gather=False)  # paced to the wall clock: at once, with what waited
    telemetry.publish(0.12, controller, gather=True)
    telemetry.flush()
    telemetry.flush()  # nothing left: no empty payload
    assert [payload.count(b"\n") + 1 for payload in control.payloads] == [10, 2, 1]
    samples = [value for payload in control.payloads for value in decode_samples(control_key(1), payload)]
    assert [round(sample["t"], 2) for sample in samples] == [round(0.01 * k, 2) for k in range(13)]
    lines, ok = encode_records(control_key(1), control.payloads[1])
    assert ok and [json.loads(line)["payload"]["t"] for line in lines] == [0.10, 0.11]
    view = TelemetryView(window_s=10.0)
    view.add(control_key(1), control.payloads[0])
    assert view.samples[control_key(1)] == 10 and not view.errors and view.last_control["t"] == 0.09
    assert session.publishers[mpc_key(1)].payloads == []  # the PID solves nothing
    # one bad line costs only itself: an error record between the good ones, an error in the view's count
    broken = control.payloads[1].replace(b"\n", b"\n{nope\n")
    lines, ok = encode_records(control_key(1), broken)
    records = [json.loads(line) for line in lines]
    assert not ok and [r["payload"]["t"] for r in records if "payload" in r] == [0.10, 0.11]
    assert records[1] == {"key": control_key(1), "error": records[1]["error"], "bytes": 5}
    assert records[1]["error"].startswith("not JSON")
    view.add(control_key(1), broken)
    assert view.samples[control_key(1)] == 13 and view.errors[control_key(1)] == 1 and view.last_control["t"] == 0.11
    with pytest.raises(ValueError, match="not JSON"):
        decode_samples(control_key(1), broken)
    # samples are split at newlines only, not at the other line separators a JSON string may hold raw
    samples = decode_samples(control_key(1), b'{"t": 1, "text": "a\xe2\x80\xa8b\xc2\x85c"}\n{"t": 2}')
    assert samples == [{"t": 1, "text": "a\u2028b\x85c"}, {"t": 2}]


def test_a_batched_plant_payload_is_a_record_a_step():
    batch = PlantStateBatch(3)
    state, command = np.arange(25.0), np.arange(12.0) + 100
    for k in range(3):
        batch.add(k * 0.0025, state + k, np.array([0.0, 0.0, -9.81]), 20.0 + k, 0.0, command)
    assert batch.full
    payload = batch.take()
    assert len(batch) == 0 and len(payload) == 3 * PLANT_STATE_BYTES
    lines, ok = encode_records(plant_state_key(1), payload)
    records = [json.loads(line)["payload"] for line in lines]
    assert ok and [r["t"] for r in records] == [0.0, 0.0025, 0.005]
    assert [r["north"] for r in records] == [0.0, 1.0, 2.0]
    assert records[2]["rudder"] == 26.0 and records[2]["on_ground"] == 0.0
    assert [r["airspeed"] for r in records] == [20.0, 21.0, 22.0] and records[1]["accel_z"] == -9.81
    assert records[0]["cmd_thrust1"] == 100.0 and records[0]["cmd_rudder"] == 111.0
    # a lockstep recording leaves out the states before the step after its first hold
    lines, ok = encode_records(plant_state_key(1), payload, plant_states_from_s=0.001)
    assert ok and [json.loads(line)["payload"]["t"] for line in lines] == [0.0025, 0.005]
    assert encode_records(plant_state_key(1), payload, plant_states_from_s=1.0) == ([], True)
    assert encode_records(plant_state_key(1), b"short", plant_states_from_s=1.0)[1] is False  # still an error record
    assert decode_plant_states(encode_plant_state(0.5, state, np.zeros(3), 1.0, 1.0, command))[0]["on_ground"] == 1.0
    view = TelemetryView(window_s=10.0)
    view.add(plant_state_key(1), payload)
    assert view.samples[plant_state_key(1)] == 3 and view.last_plant["t"] == 0.005


def test_read_recording_skips_a_cut_last_line(tmp_path):
    path = tmp_path / "r.jsonl"
    path.write_text('{"key": "a", "payload": 1}\n\n{"key": "b", "payload": [1, 2]}\n{"key": "c", "pay')
    assert [r["key"] for r in read_recording(path)] == ["a", "b"]


def test_key_expression_endpoints_and_errors():
    assert key_expression(2) == "vtol/2/**" and key_expression(None) == "vtol/**"

    class Args:
        connect, instance = None, 3

    assert endpoints_from_args(Args) == ["tcp/127.0.0.1:7450", "tcp/127.0.0.1:7550"]
    Args.connect = ["tcp/10.0.0.2:7447"]
    assert endpoints_from_args(Args) == ["tcp/10.0.0.2:7447"]
    assert short_error(ValueError("Unicast not supported for foo protocol at /x/y/lib.rs:183.")) == \
        "Unicast not supported for foo protocol"  # fmt: skip


def test_ring_buffer_keeps_a_window_thins_and_restarts():
    buffer: deque = deque()
    for k in range(4001):  # 400 Hz for 10 s
        push(buffer, {"t": k / 400}, window_s=3.0, min_dt_s=0.02)
    times = [row["t"] for row in buffer]
    assert times[-1] == 10.0 and times[0] >= 7.0 and len(times) == pytest.approx(150, abs=2)
    assert min(np.diff(times)) >= 0.02 - 1e-9
    assert push(buffer, {"t": 0.5}, window_s=3.0)  # the clock went back: a new run
    assert [row["t"] for row in buffer] == [0.5]


def test_euler_and_view_rows():
    half = math.radians(30) / 2  # 30 deg roll
    roll, pitch, yaw = euler_deg(math.cos(half), math.sin(half), 0.0, 0.0)
    assert (roll, pitch, yaw) == pytest.approx((30.0, 0.0, 0.0))
    view = TelemetryView(window_s=30.0, plant_min_dt_s=0.0)
    assert status_line(view).startswith("t=- (no plant state yet)")
    view.add(plant_state_key(1), plant_payload(t=2.0, down=-100.0, vn=3.0, q=(math.cos(half), math.sin(half), 0, 0)))
    view.add(control_key(1), control_payload(t=2.0, mode="MPC"))
    view.add(mpc_key(1), mpc_payload(t=2.0))
    line = status_line(view)
    assert re.search(r"alt=\s*100.0 m", line) and "speed=  3.0" in line and "roll=  30.0" in line
    assert "tilt=  7.5 deg" in line and "mode=MPC" in line and "mpc=2.50 ms" in line
    series = time_series(view.control, ("vn_sp", "pitch_sp"))
    assert series["vn_sp"].tolist() == [5.0] and series["pitch_sp"][0] == pytest.approx(-10.0)
    assert view.last_mpc["predicted_velocity"].shape == (26, 3)


def test_view_counts_bad_samples_and_keeps_events():
    view = TelemetryView()
    view.add(plant_state_key(1), b"\x00" * 8)
    view.add(control_key(1), b'{"t": 1}')  # JSON, but not a control sample
    view.add(mpc_key(1), json.dumps({"t": 1, "ok": True, "solve_time_ms": 1, "predicted_velocity": [1, 2]}).encode())
    assert sum(view.errors.values()) == 3 and view.last_plant is None and view.last_mpc is None
    for k in range(25):
        view.add("vtol/1/plant/events", json.dumps({"t": k, "event": "failure", "text": f"e{k}"}).encode())
    assert new_events(view, 0)[0].endswith("e5") and len(new_events(view, 0)) == 20  # ring of 20
    assert new_events(view, 23) == ["t=23.00 s e23", "t=24.00 s e24"] and new_events(view, 25) == []


def test_has_display():
    assert not has_display({}) and has_display({"DISPLAY": ":0"}) and has_display({"WAYLAND_DISPLAY": "wayland-0"})


def filled_view() -> TelemetryView:
    view = TelemetryView()
    for k in range(400):
        t = k / 100
        view.add(plant_state_key(1), plant_payload(t=t, down=-100.0 - t, vn=t))
        if k % 4 == 0:
            view.add(control_key(1), control_payload(t=t))
            view.add(mpc_key(1), mpc_payload(t=t))
    return view


def test_snapshot_writes_a_png(tmp_path):
    path = tmp_path / "watch.png"
    save_snapshot(filled_view(), path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 20_000
    save_snapshot(TelemetryView(), tmp_path / "empty.png")  # nothing received yet: still a figure
    assert (tmp_path / "empty.png").stat().st_size > 10_000


def test_window_loop_runs_on_any_backend():
    """The live window's loop, on Agg (no display here): it drains, draws, and stops when asked."""
    import warnings

    import matplotlib.pyplot as plt

    plt.switch_backend("Agg")
    view = filled_view()

    class Feed:
        drained = 0

        def drain(self, view):
            self.drained += 1
            view.add(plant_state_key(1), plant_payload(t=5.0 + self.drained / 10))
            return 1

    feed = Feed()
    checks = []

    def stop_requested():  # as if Ctrl-C came before the fourth frame
        checks.append(1)
        return len(checks) > 3

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "FigureCanvasAgg is non-interactive"
        run_window(plt, feed, view, stop_requested, time.monotonic(), None)
    assert feed.drained == 3 and view.last_plant["t"] > 5.0 and not plt.get_fignums()
    from matplotlib.figure import Figure

    artists = build_figure(Figure())
    draw(artists, view)
    assert artists["title"].get_text() == status_line(view)


# ---- the command line: bad arguments ------------------------------------------------------------------------------
@pytest.mark.parametrize("argv, message", [
    (["record"], "the following arguments are required: --out"),
    (["record", "--out", "x.jsonl", "--connect", "nonsense"], "not a zenoh endpoint"),
    (["record", "--out", "x.jsonl", "--connect", "tcp/127.0.0.1:"], "tcp endpoint without a port"),
    (["watch", "--connect", "tcp/127.0.0.1:7447", "--connect", "udp/[::1]:99999"], "udp endpoint without a port"),
    (["record", "--out", "x.jsonl", "--instance", "1", "--connect", "tcp/127.0.0.1:7447"], "not allowed with"),
    (["record", "--out", "x.jsonl", "--duration", "-1"], "must be > 0"),
    (["record", "--out", "x.jsonl", "--sysid", "0"], "must be in 1..255"),
    (["record", "--out", "/nonexistent-dir/x.jsonl"], "no such folder"),
    (["watch", "--sysid", "all"], "not an integer"),
    (["watch", "--duration", "nan"], "must be finite"),
    (["watch", "--snapshot", "/nonexistent-dir/w.png"], "no such folder"),
    (["watch", "--snapshot", "w.xyz"], "unknown image format"),
])  # fmt: skip
def test_bad_arguments_give_one_line_and_exit_code_2(capsys, argv, message):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error:" in err and message in err, err


def test_gzip_recordings_read_back_and_survive_a_cut(tmp_path) -> None:
    import gzip

    from ground_tools.telemetry_record import read_recording

    path = tmp_path / "r.jsonl.gz"
    with gzip.open(path, "wt", encoding="utf-8") as file:
        for i in range(100):
            file.write(json.dumps({"key": "vtol/1/plant/events", "payload": {"i": i}}) + "\n")
    assert [r["payload"]["i"] for r in read_recording(path)] == list(range(100))
    cut = tmp_path / "cut.jsonl.gz"
    cut.write_bytes(path.read_bytes()[:-40])  # recorder killed before the gzip trailer
    records = list(read_recording(cut))
    assert 0 < len(records) <= 100 and records[0]["payload"]["i"] == 0
