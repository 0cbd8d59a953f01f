"""`vtol watch`: a live view of a running vehicle's zenoh telemetry (docs/telemetry.md).

With a display: a matplotlib window redrawn at ~5 Hz (velocities and set-points, attitude, tilts, rotor thrust
commands, the MPC's predicted velocity over its horizon, MPC solve times). Without one (or with --text): one
status line per wall second. `--snapshot FILE.png` draws the figure (Agg, no display needed) when it stops.

Data handling is pure and zenoh-free: `TelemetryView.add(key, payload)` decodes a sample into ring buffers of
the last WINDOW_S seconds of simulation time; `status_line`, `time_series` and `draw` read it. zenoh's threads
only queue (key, bytes); the main loop feeds the view.
"""

from __future__ import annotations

import math
import os
import queue
import sys
import time
from collections import Counter, deque
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ground_tools.telemetry_record import (
    add_source_arguments,
    decode_payload,
    endpoints_from_args,
    key_expression,
    short_error,
    sysid_from_args,
)
from transport.cli import fail, stop_on_signals

PROG = "vtol"
WINDOW_S = 30.0  # simulation seconds kept in the ring buffers
PLANT_MIN_DT_S = 0.02  # plant rows kept at most every 20 ms of simulation time (the plant publishes at 400 Hz)
REDRAW_S = 0.2  # window refresh period (wall)
STATUS_S = 1.0  # text status period (wall)
GUI_BACKENDS = ("QtAgg", "TkAgg", "GTK4Agg", "GTK3Agg")
PLOTTED_PLANT = ("speed", "vn", "ve", "vd", "roll", "pitch", "yaw", *(f"tilt{i}" for i in range(1, 5)),
                 *(f"thrust{i}" for i in range(1, 5)))  # fmt: skip


def euler_deg(qw: float, qx: float, qy: float, qz: float) -> tuple[float, float, float]:
    """ZYX roll, pitch, yaw (deg) of the body FRD -> NED quaternion."""
    roll = math.atan2(2 * (qw * qx + qy * qz), 1 - 2 * (qx * qx + qy * qy))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (qw * qy - qz * qx))))
    yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
    return math.degrees(roll), math.degrees(pitch), math.degrees(yaw)


def plant_row(state: dict[str, float]) -> dict[str, float]:
    """What the view keeps of one plant state: time, altitude, velocities, attitude (deg), tilts (deg), thrust."""
    roll, pitch, yaw = euler_deg(state["qw"], state["qx"], state["qy"], state["qz"])
    row = {
        "t": state["t"],
        "alt": -state["down"],
        "vn": state["vn"],
        "ve": state["ve"],
        "vd": state["vd"],
        "speed": math.sqrt(state["vn"] ** 2 + state["ve"] ** 2 + state["vd"] ** 2),
        "roll": roll,
        "pitch": pitch,
        "yaw": yaw,
    }
    for i in range(1, 5):
        row[f"tilt{i}"] = math.degrees(state[f"tilt{i}"])
        row[f"thrust{i}"] = state[f"cmd_thrust{i}"]
    row["tilt_mean"] = sum(row[f"tilt{i}"] for i in range(1, 5)) / 4
    return row


def control_row(control: dict) -> dict[str, Any]:
    """What the view keeps of one autopilot/control sample: time, velocity and attitude set-points, mode."""
    vsp, esp = control["velocity_sp"], control["euler_sp"]
    return {
        "t": float(control["t"]),
        "vn_sp": float(vsp[0]),
        "ve_sp": float(vsp[1]),
        "vd_sp": float(vsp[2]),
        "roll_sp": math.degrees(esp[0]),
        "pitch_sp": math.degrees(esp[1]),
        "yaw_sp": math.degrees(esp[2]),
        "mode": str(control["mode"]),
    }


def push(buffer: deque, row: dict, window_s: float, min_dt_s: float = 0.0) -> bool:
    """Append `row` to a time-ordered ring buffer and drop rows older than `window_s` before it. A time going
    back (a new run) empties the buffer first. Rows closer than `min_dt_s` to the last kept one are skipped.
    Returns whether the row was kept."""
    t = row["t"]
    if buffer:
        last = buffer[-1]["t"]
        if t < last:
            buffer.clear()
        elif t - last < min_dt_s - 1e-9:
            return False
    buffer.append(row)
    while buffer[0]["t"] < t - window_s:
        buffer.popleft()
    return True


def time_series(buffer: deque, names: tuple[str, ...] | list[str]) -> dict[str, np.ndarray]:
    """Columns of a ring buffer as arrays ("t" included)."""
    return {name: np.array([row[name] for row in buffer], dtype=float) for name in ("t", *names)}


class TelemetryView:
    """Ring buffers of one vehicle's telemetry (the last `window_s` simulation seconds) and the latest samples."""

    def __init__(self, window_s: float = WINDOW_S, plant_min_dt_s: float = PLANT_MIN_DT_S) -> None:
        self.window_s = window_s
        self.plant_min_dt_s = plant_min_dt_s
        self.plant: deque[dict] = deque()
        self.control: deque[dict] = deque()
        self.solves: deque[dict] = deque()  # {"t", "ms", "ok"}
        self.last_plant: dict[str, float] | None = None  # the latest row (also the ones thinned out)
        self.last_control: dict | None = None
        self.last_mpc: dict | None = None
        self.events: deque[str] = deque(maxlen=20)
        self.events_total = 0
        self.samples: Counter[str] = Counter()
        self.errors: Counter[str] = Counter()
        self.last_error: str = ""

    def add(self, key: str, payload: bytes) -> None:
        """Decode one sample and file it; a sample that does not decode is counted in `errors`, never raised."""
        self.samples[key] += 1
        try:
            self.add_decoded(key, decode_payload(key, payload))
        except (ValueError, KeyError, IndexError, TypeError) as exc:
            self.errors[key] += 1
            self.last_error = f"{key}: {exc!r}"

    def add_decoded(self, key: str, value: Any) -> None:
        if key.endswith("/plant/state"):
            row = plant_row(value)
            self.last_plant = row
            push(self.plant, row, self.window_s, self.plant_min_dt_s)
        elif key.endswith("/autopilot/control"):
            row = control_row(value)
            self.last_control = row
            push(self.control, row, self.window_s)
        elif key.endswith("/autopilot/mpc"):
            predicted = np.asarray(value["predicted_velocity"], dtype=float)
            if predicted.ndim != 2 or predicted.shape[1] != 3:
                raise ValueError(f"predicted_velocity has shape {predicted.shape}, expected (N+1, 3)")
            self.last_mpc = {"t": float(value["t"]), "ms": float(value["solve_time_ms"]),
                             "ok": bool(value["ok"]), "status": str(value.get("status", "")),
                             "predicted_velocity": predicted}  # fmt: skip
            push(self.solves, {"t": self.last_mpc["t"], "ms": self.last_mpc["ms"], "ok": self.last_mpc["ok"]},
                 self.window_s)  # fmt: skip
        elif key.endswith("/events"):
            self.events_total += 1
            if isinstance(value, dict):
                self.events.append(f"t={float(value.get('t', math.nan)):.2f} s {value.get('text', value)}")
            else:
                self.events.append(str(value))


def status_line(view: TelemetryView) -> str:
    """One compact line: sim time, altitude, speed, roll/pitch/yaw, mean tilt, mode, MPC solve time."""
    p = view.last_plant
    mode = view.last_control["mode"] if view.last_control else "-"
    mpc = f"{view.last_mpc['ms']:.2f} ms" if view.last_mpc else "-"
    if view.last_mpc and not view.last_mpc["ok"]:
        mpc += " FAILED"
    if p is None:
        return f"t=- (no plant state yet)  mode={mode}  mpc={mpc}"
    return (f"t={p['t']:8.2f} s  alt={p['alt']:7.1f} m  speed={p['speed']:5.1f} m/s  "
            f"roll={p['roll']:6.1f} pitch={p['pitch']:6.1f} yaw={p['yaw']:6.1f} deg  "
            f"tilt={p['tilt_mean']:5.1f} deg  mode={mode}  mpc={mpc}")  # fmt: skip


# ---- the figure ----------------------------------------------------------------------------------------------------
def build_figure(figure: Any) -> dict[str, Any]:
    """Axes and (empty) lines of the live view on a matplotlib Figure; returns the artists by name."""
    axes = figure.subplots(3, 2)
    figure.set_size_inches(13, 9)
    artists: dict[str, Any] = {"axes": axes}
    colours = {"speed": "k", "vn": "C0", "ve": "C1", "vd": "C2", "roll": "C0", "pitch": "C1", "yaw": "C2"}
    spec = [
        (axes[0, 0], "velocity (m/s, NED)", [("speed", "|v|"), ("vn", "v_n"), ("ve", "v_e"), ("vd", "v_d")]),
        (axes[0, 1], "attitude (deg)", [("roll", "roll"), ("pitch", "pitch"), ("yaw", "yaw")]),
        (axes[1, 0], "tilt (deg)", [(f"tilt{i}", f"servo {i}") for i in range(1, 5)]),
        (axes[1, 1], "rotor thrust command (fraction)", [(f"thrust{i}", f"rotor {i}") for i in range(1, 5)]),
    ]
    for axis, title, lines in spec:
        for name, label in lines:
            (artists[name],) = axis.plot([], [], label=label, color=colours.get(name), linewidth=1.2)
        axis.set_title(title, fontsize="medium")
        axis.set_xlabel("t (s, simulation)")
        axis.grid(True, alpha=0.3)
    for name, axis in (("vn", axes[0, 0]), ("ve", axes[0, 0]), ("vd", axes[0, 0]),
                       ("roll", axes[0, 1]), ("pitch", axes[0, 1]), ("yaw", axes[0, 1])):  # fmt: skip
        (artists[f"{name}_sp"],) = axis.plot([], [], linestyle="--", color=colours[name], linewidth=1.0,
                                             label="set-points" if name in ("vn", "roll") else None)  # fmt: skip
    for axis in axes[0, 0], axes[0, 1], axes[1, 0], axes[1, 1]:
        axis.legend(loc="upper left", fontsize="x-small", ncol=3)
    horizon = axes[2, 0]
    for i, name in enumerate(("vn", "ve", "vd")):
        (artists[f"mpc_{name}"],) = horizon.plot([], [], marker=".", color=f"C{i}", label=f"{name} predicted")
    for i, name in enumerate(("vn", "ve", "vd")):
        (artists[f"mpc_{name}_sp"],) = horizon.plot([], [], linestyle="--", color=f"C{i}", linewidth=1.0)
    artists["mpc_note"] = horizon.text(0.5, 0.5, "no MPC solution received", transform=horizon.transAxes,
                                       ha="center", va="center", color="0.5")  # fmt: skip
    artists["mpc_title"] = horizon.set_title("MPC predicted velocity (m/s)", fontsize="medium")
    horizon.set_xlabel("horizon stage")
    horizon.grid(True, alpha=0.3)
    horizon.legend(loc="upper left", fontsize="x-small", ncol=3)
    solve = axes[2, 1]
    (artists["solve_ms"],) = solve.plot([], [], color="C3", linewidth=1.0)
    solve.set_title("MPC solve time (ms)", fontsize="medium")
    solve.set_xlabel("t (s, simulation)")
    solve.grid(True, alpha=0.3)
    artists["title"] = figure.suptitle("waiting for telemetry...", fontsize="small", family="monospace")
    figure.tight_layout(rect=(0, 0, 1, 0.96))
    return artists


def draw(artists: dict[str, Any], view: TelemetryView) -> None:
    """Put the view's buffers into the figure's lines and rescale the axes."""
    plant = time_series(view.plant, PLOTTED_PLANT)
    for name, values in plant.items():
        if name != "t":
            artists[name].set_data(plant["t"], values)
    control = time_series(view.control, ("vn_sp", "ve_sp", "vd_sp", "roll_sp", "pitch_sp", "yaw_sp"))
    for name, values in control.items():
        if name != "t":
            artists[name].set_data(control["t"], values)
    solves = time_series(view.solves, ("ms",))
    artists["solve_ms"].set_data(solves["t"], solves["ms"])
    if view.last_mpc is not None:
        predicted = view.last_mpc["predicted_velocity"]
        stages = np.arange(predicted.shape[0])
        for i, name in enumerate(("vn", "ve", "vd")):
            artists[f"mpc_{name}"].set_data(stages, predicted[:, i])
            if view.last_control is not None:  # the set-point the horizon aims at (dashed)
                artists[f"mpc_{name}_sp"].set_data(stages[[0, -1]], [view.last_control[f"{name}_sp"]] * 2)
        artists["mpc_note"].set_visible(False)
        artists["mpc_title"].set_text(f"MPC predicted velocity (m/s) at t = {view.last_mpc['t']:.2f} s"
                                      + ("" if view.last_mpc["ok"] else f" FAILED ({view.last_mpc['status']})"))
    latest = max((b[-1]["t"] for b in (view.plant, view.control, view.solves) if b), default=None)
    axes = artists["axes"]
    for axis in axes.flat:
        axis.relim()
        axis.autoscale_view()
        if latest is not None and axis is not axes[2, 0]:
            axis.set_xlim(max(0.0, latest - view.window_s), max(latest, 1.0))
    artists["title"].set_text(status_line(view))


def save_snapshot(view: TelemetryView, path: Path) -> None:
    """Draw the view into a new Agg figure and write it (format from the suffix)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure()
    FigureCanvasAgg(figure)
    draw(build_figure(figure), view)
    figure.savefig(path, dpi=90)


# ---- the command -----------------------------------------------------------------------------------------------
def add_watch_arguments(parser: Any) -> None:
    add_source_arguments(parser, allow_all=False)
    parser.add_argument("--snapshot", metavar="FILE.png", help="write the figure to FILE when the watch ends")
    parser.add_argument("--text", action="store_true", help="status lines even when a display is available")


def has_display(environ: Mapping[str, str] = os.environ) -> bool:
    return bool(environ.get("DISPLAY") or environ.get("WAYLAND_DISPLAY"))


def gui_pyplot() -> Any | None:
    """pyplot on an interactive backend, or None if none works here (ground_tools.figures selects Agg)."""
    import matplotlib.pyplot as plt

    wanted = os.environ.get("MPLBACKEND")
    for backend in ((wanted,) if wanted else ()) + GUI_BACKENDS:
        try:
            plt.switch_backend(backend)
        except Exception:  # ImportError or a toolkit that cannot start
            continue
        if plt.get_backend().lower() not in ("agg", "pdf", "svg", "ps", "cairo", "pgf", "template"):
            return plt
    return None


class Subscription:
    """A zenoh session subscribed to `vtol/<sysid>/**`; samples wait in `queue` as (key, bytes)."""

    def __init__(self, endpoints: list[str], sysid: int) -> None:
        import zenoh

        from transport.zenoh_bus import session_config

        self.queue: queue.SimpleQueue = queue.SimpleQueue()
        self.session = zenoh.open(session_config(listen=[], connect=endpoints))
        self.subscriber = self.session.declare_subscriber(key_expression(sysid), self._on_sample)

    def _on_sample(self, sample: Any) -> None:
        try:
            self.queue.put((str(sample.key_expr), sample.payload.to_bytes()))
        except Exception:
            pass  # a sample zenoh could not hand over; the view counts what it gets

    def drain(self, view: TelemetryView, limit: int = 100_000) -> int:
        n = 0
        while n < limit:
            try:
                key, payload = self.queue.get_nowait()
            except queue.Empty:
                break
            view.add(key, payload)
            n += 1
        return n

    def close(self) -> None:
        try:
            self.subscriber.undeclare()
            self.session.close()
        except Exception:
            pass


def watch(args: Any) -> int:
    """`vtol watch`: see module docstring. Ends on Ctrl-C, SIGTERM, --duration (wall s) or the window closing."""
    endpoints = endpoints_from_args(args)
    sysid = sysid_from_args(args) or 1  # watch takes one vehicle (no `all`)
    snapshot = Path(args.snapshot) if args.snapshot else None
    if snapshot is not None:
        check_snapshot_path(snapshot)
    plt = None
    if not args.text and has_display():
        plt = gui_pyplot()
        if plt is None:
            print(f"{PROG}: no interactive matplotlib backend here; text mode", file=sys.stderr)
    try:
        subscription = Subscription(endpoints, sysid)
    except Exception as exc:
        fail(PROG, f"cannot open a zenoh session to {', '.join(endpoints)}: {short_error(exc)}")
    stop_requested = stop_on_signals()
    print(f"{PROG}: watching vtol/{sysid}/** from {', '.join(endpoints)}; Ctrl-C stops", file=sys.stderr,
          flush=True)  # fmt: skip
    view = TelemetryView()
    start = time.monotonic()
    try:
        if plt is not None:
            run_window(plt, subscription, view, stop_requested, start, args.duration, f"vtol watch: sysid {sysid}")
        else:
            run_text(subscription, view, stop_requested, start, args.duration)
        subscription.drain(view)
    finally:
        subscription.close()
    if snapshot is not None:
        try:
            save_snapshot(view, snapshot)
        except (OSError, ValueError) as exc:
            fail(PROG, f"cannot write the snapshot {snapshot}: {exc}")
        print(f"{PROG}: snapshot {snapshot}", file=sys.stderr)
    received = sum(view.samples.values())
    errors = sum(view.errors.values())
    print(f"{PROG}: {received} samples received" + (f", {errors} undecodable (last: {view.last_error})"
                                                   if errors else ""), file=sys.stderr)  # fmt: skip
    return 0


def check_snapshot_path(path: Path) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    formats = FigureCanvasAgg(Figure()).get_supported_filetypes()
    if path.suffix.lower().lstrip(".") not in formats:
        fail(PROG, f"--snapshot: unknown image format {path.suffix!r} (use .png, .pdf or .svg)")
    if not path.parent.is_dir():
        fail(PROG, f"--snapshot: no such folder: {path.parent}")


def _ended(stop_requested: Any, start: float, duration: float | None) -> bool:
    return stop_requested() or (duration is not None and time.monotonic() - start >= duration)


def new_events(view: TelemetryView, shown: int) -> list[str]:
    """The events filed since `shown` of them were (at most the ring's length)."""
    fresh = min(view.events_total - shown, len(view.events))
    return list(view.events)[len(view.events) - fresh:] if fresh > 0 else []


def run_text(subscription: Subscription, view: TelemetryView, stop_requested: Any, start: float,
             duration: float | None) -> None:  # fmt: skip
    """One status line per wall second, and each plant/autopilot event as it comes."""
    next_line = start + STATUS_S
    shown_events = 0
    received_before = 0
    last_line = start
    while True:
        ended = _ended(stop_requested, start, duration)
        subscription.drain(view)
        for text in new_events(view, shown_events):
            print(f"event: {text}", flush=True)
        shown_events = view.events_total
        now = time.monotonic()
        if now >= next_line or (ended and now - last_line > 0.5 * STATUS_S):
            last_line = now
            received = sum(view.samples.values())
            print(status_line(view) + ("" if received > received_before else "  (no new samples)"), flush=True)
            received_before = received
            while next_line <= now:
                next_line += STATUS_S
        if ended:
            return
        time.sleep(max(0.0, min(0.05, next_line - time.monotonic())))


def run_window(plt: Any, subscription: Subscription, view: TelemetryView, stop_requested: Any, start: float,
               duration: float | None, title: str = "vtol watch") -> None:  # fmt: skip
    """The live figure, redrawn every REDRAW_S until stopped or closed."""
    plt.ion()
    figure = plt.figure(num=title)
    artists = build_figure(figure)
    plt.show(block=False)
    while not _ended(stop_requested, start, duration) and plt.fignum_exists(figure.number):
        began = time.monotonic()
        subscription.drain(view)
        draw(artists, view)
        figure.canvas.draw_idle()
        figure.canvas.flush_events()
        time.sleep(max(0.0, REDRAW_S - (time.monotonic() - began)))
    plt.close(figure)
