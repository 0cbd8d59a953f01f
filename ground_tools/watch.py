"""`vtol watch`: a live view of a running vehicle's zenoh telemetry (docs/telemetry.md).

With a display: a matplotlib window redrawn at ~5 Hz (velocities and set-points, attitude, tilts, rotor thrust
commands, the MPC's predicted velocity over its horizon, MPC solve times). Without one (or with --text): one
status line per wall second. `--snapshot FILE.png` draws the figure (Agg, no display needed) when it stops.

The data (ground_tools/telemetry_view.py) and the figure (ground_tools/watch_figure.py) are zenoh-free; zenoh's
subscriber keeps the samples in a FIFO channel, and the main loop feeds the view from it.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ground_tools.exit_status import FAILED, OK, epilog
from ground_tools.telemetry_record import (
    CHANNEL_CAPACITY,
    add_source_arguments,
    endpoints_from_args,
    key_expression,
    short_error,
    sysid_from_args,
)
from ground_tools.telemetry_view import TelemetryView, status_line
from ground_tools.watch_figure import build_figure, draw, save_snapshot
from transport.cli import fail, stop_on_signals

PROG = "vtol"
REDRAW_S = 0.2  # window refresh period (wall)
STATUS_S = 1.0  # text status period (wall)
GUI_BACKENDS = ("QtAgg", "TkAgg", "GTK4Agg", "GTK3Agg")


EPILOG = epilog(ok="samples were received", failed="nothing was received (is a vehicle publishing there?)")


def add_watch_arguments(parser: Any) -> None:
    parser.epilog = EPILOG
    add_source_arguments(parser, allow_all=False)
    parser.add_argument("--snapshot", metavar="FILE.png", help="write the figure to FILE when the watch ends")
    parser.add_argument("--text", action="store_true", help="status lines even when a display is available")


def has_display(environ: Mapping[str, str] = os.environ) -> bool:
    return bool(environ.get("DISPLAY") or environ.get("WAYLAND_DISPLAY"))


def gui_pyplot() -> Any | None:
    """pyplot on an interactive backend, or None if none works here (the figure files use Agg instead:
    ground_tools.figures.pyplot)."""
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
    """A zenoh session subscribed to `vtol/<sysid>/**`; zenoh keeps the samples in a FIFO channel (as the recorder's,
    so a 400 Hz stream costs no Python call per sample) until the main loop drains them into the view."""

    def __init__(self, endpoints: list[str], sysid: int) -> None:
        import zenoh

        from transport.zenoh_bus import session_config

        self.session = zenoh.open(session_config(listen=[], connect=endpoints))
        channel = zenoh.handlers.FifoChannel(CHANNEL_CAPACITY)
        self.subscriber = self.session.declare_subscriber(key_expression(sysid), channel)

    def drain(self, view: TelemetryView, limit: int = 100_000) -> int:
        n = 0
        while n < limit and (sample := self.subscriber.try_recv()) is not None:
            view.add(str(sample.key_expr), sample.payload.to_bytes())
            n += 1
        return n

    def close(self) -> None:
        try:
            self.subscriber.undeclare()
            self.session.close()
        except Exception as exc:  # the session is going away in any case
            print(f"vtol: warning: closing the watch's zenoh session: {short_error(exc)}", file=sys.stderr)


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
    return OK if received else FAILED


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
    return list(view.events)[len(view.events) - fresh :] if fresh > 0 else []


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
