"""Record zenoh telemetry (docs/telemetry.md) to a JSON-lines file: `vtol record` and the scenario runner.

One JSON object per line, in arrival order (gzip-compressed when the file name ends in .gz):

    {"key": "vtol/1/plant/state", "payload": {"t": 0.0025, "north": 0.0, ...}}    plant state, decoded (a line a step)
    {"key": "vtol/1/autopilot/control", "payload": {"t": 0.01, "mode": "MC", ...}} a line a JSON sample
    {"key": "vtol/1/plant/state", "error": "plant state payload has 24 bytes, expected a multiple of 344", "bytes": 24}

A sample that cannot be decoded is written as an error record (never dropped, never fatal) and counted in
`errors`. zenoh queues the samples in a FIFO channel on its own threads; one writer thread drains it every
DRAIN_S, decodes and writes. `stop()` returns once everything received before it is on disk.
"""

from __future__ import annotations

import argparse
import gzip
import json
import math
import re
import sys
import threading
import time
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import orjson

from ground_tools.exit_status import FAILED, OK, epilog
from ground_tools.progress import advance_to, counter
from transport.cli import bounded_int, fail, positive_float, stop_on_signals
from transport.ports import Ports
from transport.telemetry import PLANT_STATE_FIELDS, decode_plant_states, plant_state_rows
from transport.zenoh_bus import session_config

FLUSH_S = 0.5  # the file is flushed at least this often (wall s), so a killed recorder loses little
DRAIN_S = 0.02  # the writer empties zenoh's channel this often (wall s)
CHANNEL_CAPACITY = 1 << 17  # samples zenoh keeps for the writer: over 5 minutes of a 400 Hz stream


def key_expression(sysid: int | None) -> str:
    """What the recorder subscribes to: one vehicle's keys, or every vehicle's."""
    return "vtol/**" if sysid is None else f"vtol/{sysid}/**"


def _parse_json(text: str) -> Any:
    """One JSON value; ValueError (with the reason) if `text` is not one."""
    try:
        return orjson.loads(text)
    except orjson.JSONDecodeError:
        pass  # strict JSON: Python's json also reads NaN / Infinity, which other publishers may send
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"not JSON: {exc.msg} at character {exc.pos}") from None
    except RecursionError:
        raise ValueError("not JSON that can be read: nested too deeply") from None


@dataclass(frozen=True)
class JsonSample:
    """One sample of a JSON payload: its text and value, or why it is not JSON (`error`); `size` in bytes."""

    text: str
    size: int
    value: Any = None
    error: str | None = None


def _json_sample(text: str) -> JsonSample:
    try:
        return JsonSample(text, len(text.encode()), _parse_json(text))
    except ValueError as exc:
        return JsonSample(text, len(text.encode()), error=str(exc))


def json_samples(payload: bytes) -> list[JsonSample]:
    """A JSON payload's samples: one JSON value, or several, one a line (the autopilot's batches,
    docs/telemetry.md). A line that is not JSON is a sample with its error, and the lines around it are kept; a
    payload that is not UTF-8 is one sample with that error."""
    try:
        text = payload.decode("utf-8")
    except UnicodeDecodeError as exc:
        return [JsonSample("", len(payload), error=f"not UTF-8: {exc.reason} at byte {exc.start}")]
    try:
        return [JsonSample(text, len(payload), orjson.loads(text))]
    except orjson.JSONDecodeError:
        pass
    lines = [line for line in text.split("\n") if line.strip()]
    if len(lines) > 1:
        samples = [_json_sample(line) for line in lines]
        if any(sample.error is None for sample in samples):
            return samples
    return [_json_sample(text)]  # one value over several lines, one with NaN (Python's json reads it), or one error


def decoded_samples(key: str, payload: bytes) -> tuple[list[Any], list[str]]:
    """A payload's samples as JSON-able data, and why the others did not decode: plant/state -> a dict of
    PLANT_STATE_FIELDS per physics step (a payload of the wrong size is one error), any other key -> its JSON
    samples (`json_samples`)."""
    if key.endswith("/plant/state"):
        try:
            return decode_plant_states(payload), []
        except ValueError as exc:
            return [], [str(exc)]
    samples = json_samples(payload)
    return [s.value for s in samples if s.error is None], [s.error for s in samples if s.error is not None]


def decode_samples(key: str, payload: bytes) -> list[Any]:
    """A payload's samples (`decoded_samples`); ValueError (with the reason) if any of them does not decode."""
    values, errors = decoded_samples(key, payload)
    if errors:
        raise ValueError(errors[0])
    return values


def _json_record(key: str, head: str, sample: JsonSample) -> str:
    if sample.error is not None:
        return json.dumps({"key": key, "error": sample.error, "bytes": sample.size})
    if "\n" in sample.text or "\r" in sample.text:  # one record a line
        return json.dumps({"key": key, "payload": sample.value})
    return head + sample.text + "}"


def encode_records(key: str, payload: bytes, plant_states_from_s: float = -math.inf) -> tuple[list[str], bool]:
    """A payload's recording lines (one per sample, without the newline; an error record for each sample that does
    not decode) and whether all of it decoded. Each line is the JSON of {"key": key, "payload": sample}, built with
    orjson or from the payload's own text where that is cheaper: a recorded flight's samples are encoded while it
    flies, on the cores it flies on. Plant states before `plant_states_from_s` (simulation s) are left out."""
    head = f'{{"key": {json.dumps(key)}, "payload": '
    if not key.endswith("/plant/state"):
        samples = json_samples(payload)
        return [_json_record(key, head, sample) for sample in samples], all(s.error is None for s in samples)
    try:
        rows = plant_state_rows(payload)
    except ValueError as exc:
        return [json.dumps({"key": key, "error": str(exc), "bytes": len(payload)})], False
    rows = rows[rows[:, 0] >= plant_states_from_s]
    if np.isfinite(rows).all():  # (orjson would write a non-finite number as null)
        return [head + orjson.dumps(dict(zip(PLANT_STATE_FIELDS, row))).decode() + "}" for row in rows.tolist()], True
    return [json.dumps({"key": key, "payload": dict(zip(PLANT_STATE_FIELDS, row))}) for row in rows.tolist()], True


def _open_text(path: Path, mode: str) -> Any:
    """A recording file: gzip-compressed when its name ends in .gz (level 1: cheap, about 4x smaller)."""
    if path.suffix == ".gz":
        return gzip.open(path, mode + "t", encoding="utf-8", compresslevel=1)
    return open(path, mode, encoding="utf-8")


def read_recording(path: Path | str) -> Iterator[dict]:
    """The records of a recording (.jsonl or .jsonl.gz), in order. A last line cut short (recorder killed
    mid-write, also inside a gzip stream) is skipped."""
    with _open_text(Path(path), "r") as file:
        lines = iter(file)
        while True:
            try:
                line = next(lines)
            except (StopIteration, EOFError):  # EOFError: a gzip stream cut short
                return
            if not line.endswith("\n"):
                return
            if line.strip():
                yield json.loads(line)


class TelemetryRecorder:
    """Subscribe to `vtol/<sysid>/**` (every vehicle when sysid is None) through a loopback-by-default zenoh
    peer session that connects to `endpoints`, and write every sample to `path` (JSON lines).

    `counts` (records per key, errors included) and `errors` (undecodable samples per key) grow while
    recording; `stop()` returns `counts`. Usable as a context manager.

    `plant_states_from_s` (simulation s): plant states before it are not recorded. A lockstep recording that
    subscribes while the simulation is held sets it to just after the held step: that step's state was put when
    the hold began, racing the subscription, so without it a recording would start at that step in some runs and
    at the next one in others (docs/telemetry.md)."""

    def __init__(self, endpoints: list[str], path: Path, sysid: int | None,
                 plant_states_from_s: float = -math.inf) -> None:  # fmt: skip
        self.endpoints = list(endpoints)
        self.path = Path(path)
        self.sysid = sysid
        self.plant_states_from_s = plant_states_from_s
        self.counts: Counter[str] = Counter()
        self.errors: Counter[str] = Counter()
        self._stopping = threading.Event()
        self._session: Any = None
        self._subscriber: Any = None
        self._writer: threading.Thread | None = None
        self._file: Any = None
        self._write_error: BaseException | None = None
        self._stopped = False

    def start(self) -> TelemetryRecorder:
        """Open the output file and the session, subscribe. Raises OSError (file) or zenoh's error (endpoints)."""
        import zenoh

        if self._writer is not None:
            raise RuntimeError("the recorder was already started")
        self._file = _open_text(self.path, "w")
        try:
            self._session = zenoh.open(session_config(listen=[], connect=self.endpoints))
            # zenoh's own threads queue the samples without Python; the writer drains them every DRAIN_S, so a
            # 400 Hz stream wakes this process 50 times a second rather than once per sample.
            channel = zenoh.handlers.FifoChannel(CHANNEL_CAPACITY)
            self._subscriber = self._session.declare_subscriber(key_expression(self.sysid), channel)
        except BaseException:
            self._file.close()
            if self._session is not None:
                self._session.close()
            raise
        self._writer = threading.Thread(target=self._write_loop, name="telemetry-recorder", daemon=True)
        self._writer.start()
        return self

    def _write_loop(self) -> None:
        flushed = time.monotonic()
        while True:
            last_round = self._stopping.is_set()
            self._drain()
            if last_round:
                break
            if time.monotonic() - flushed >= FLUSH_S:
                self._flush()
                flushed = time.monotonic()
            self._stopping.wait(DRAIN_S)
        self._flush()

    def _drain(self) -> None:
        """Write every sample waiting in the channel."""
        while (sample := self._subscriber.try_recv()) is not None:
            key = str(sample.key_expr)
            lines, ok = encode_records(key, sample.payload.to_bytes(), self.plant_states_from_s)
            self.counts[key] += len(lines)
            if not ok:
                self.errors[key] += 1
            if self._write_error is None:
                try:
                    self._file.write("".join(line + "\n" for line in lines))
                except OSError as exc:  # disk full: keep counting, report at stop()
                    self._write_error = exc

    def _flush(self) -> None:
        if self._write_error is None:
            try:
                self._file.flush()
            except OSError as exc:
                self._write_error = exc

    def stop(self) -> dict[str, int]:
        """Stop receiving, write out everything received so far, close the session and the file; counts per key.
        Raises the first OSError met while writing, if any (after closing everything)."""
        if self._writer is None or self._stopped:
            return dict(self.counts)
        self._stopped = True
        self._stopping.set()
        self._writer.join()  # its last round drained what had arrived
        try:
            self._subscriber.undeclare()
            self._session.close()
        except Exception as exc:  # the session is going away in any case; the recording is what matters
            print(f"vtol: warning: closing the recorder's zenoh session: {short_error(exc)}", file=sys.stderr)
        try:
            self._file.close()
        except OSError as exc:
            self._write_error = self._write_error or exc
        self._subscriber = self._session = None
        if self._write_error is not None:
            error, self._write_error = self._write_error, None
            raise error
        return dict(self.counts)

    def wait_for_peers(self, count: int, timeout_s: float) -> bool:
        """Wait until the session is connected to `count` peers (e.g. the plant and the autopilot), then a moment
        for the subscription to reach them; False if that did not happen within timeout_s."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if len(list(self._session.info.peers_zid())) >= count:
                time.sleep(0.2)
                return True
            time.sleep(0.02)
        return False

    def __enter__(self) -> TelemetryRecorder:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


# ---- `vtol record` (and the options `vtol watch` shares) -----------------------------------------------------------
PROG = "vtol"
_ENDPOINT = re.compile(r"[A-Za-z][A-Za-z0-9-]*/\S+")
_HOST_PORT_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws")
_PORT = re.compile(r"\S:(\d{1,5})$")


def zenoh_endpoint(text: str) -> str:
    """An argparse type: `<protocol>/<address>`, e.g. tcp/127.0.0.1:7447 (zenoh checks the rest)."""
    if not _ENDPOINT.fullmatch(text):
        raise argparse.ArgumentTypeError(f"not a zenoh endpoint <protocol>/<address> (e.g. tcp/127.0.0.1:7447): "
                                         f"{text!r}")  # fmt: skip
    protocol, address = text.split("/", 1)
    if protocol in _HOST_PORT_PROTOCOLS:
        port = _PORT.search(address.split("?", 1)[0].split("#", 1)[0])
        if port is None or not 1 <= int(port.group(1)) <= 65535:
            raise argparse.ArgumentTypeError(f"{protocol} endpoint without a port 1..65535 (<host>:<port>): {text!r}")
    return text


ALL_SYSIDS = 0  # `--sysid all` as parsed; sysid_from_args turns it into None (every vehicle)


def sysid_or_all(text: str) -> int:
    """An argparse type: a system id 1..255, or `all` (ALL_SYSIDS)."""
    return ALL_SYSIDS if text == "all" else bounded_int(1, 255)(text)


def add_source_arguments(parser: argparse.ArgumentParser, *, allow_all: bool) -> None:
    """--instance I | --connect ENDPOINT..., --sysid N, --duration S (wall seconds)."""
    source = parser.add_mutually_exclusive_group()
    source.add_argument(
        "--instance",
        type=bounded_int(0, 999),
        default=0,
        metavar="I",
        help="connect to instance I's plant and autopilot (tcp/127.0.0.1:7447+I and :7547+I)",
    )
    source.add_argument(
        "--connect",
        type=zenoh_endpoint,
        action="append",
        metavar="ENDPOINT",
        help="zenoh endpoint to connect to instead (repeatable), e.g. tcp/<host>:7447",
    )
    parser.add_argument(
        "--sysid",
        type=sysid_or_all if allow_all else bounded_int(1, 255),
        default=None,
        metavar="N",
        help="vehicle system id (default I+1, the instance's; 1 with --connect)"
        + ("; 'all' for every vehicle" if allow_all else ""),
    )
    parser.add_argument(
        "--duration",
        type=positive_float,
        metavar="S",
        help="stop after S wall-clock seconds (default: at Ctrl-C or SIGTERM)",
    )


RECORD_EPILOG = epilog(ok="samples were recorded", failed="nothing was received (is a vehicle publishing there?), "
                       "or the file could not be written")  # fmt: skip


def add_record_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = RECORD_EPILOG
    parser.add_argument("--out", required=True, metavar="FILE.jsonl", help="the recording (JSON lines; replaced)")
    add_source_arguments(parser, allow_all=True)
    parser.add_argument("--no-progress", action="store_true", help="no running count of the samples recorded")


def sysid_from_args(args: Any) -> int | None:
    """--sysid, else the instance's system id (I + 1), or 1 with --connect."""
    if args.sysid == ALL_SYSIDS:
        return None
    if args.sysid is not None:
        return args.sysid
    return 1 if args.connect else Ports(args.instance).system_id


def endpoints_from_args(args: Any) -> list[str]:
    """--connect's endpoints, or instance I's plant and autopilot endpoints (loopback)."""
    if args.connect:
        return list(args.connect)
    ports = Ports(args.instance)
    return [ports.zenoh_plant, ports.zenoh_autopilot]


def short_error(exc: BaseException) -> str:
    """zenoh's error text without its source locations, on one line."""
    text = " ".join(str(exc).split())
    return re.sub(r" at /\S+?\.rs:\d+\.?", "", text) or type(exc).__name__


def record(args: Any) -> int:
    """`vtol record`: until Ctrl-C, SIGTERM or --duration; prints the samples recorded per key."""
    endpoints = endpoints_from_args(args)
    out = Path(args.out)
    if out.is_dir():
        fail(PROG, f"--out: {out} is a folder")
    if not out.parent.is_dir():
        fail(PROG, f"--out: no such folder: {out.parent}")
    sysid = sysid_from_args(args)
    recorder = TelemetryRecorder(endpoints, out, sysid)
    try:
        recorder.start()
    except OSError as exc:
        fail(PROG, f"cannot write {out}: {exc.strerror or exc}")
    except Exception as exc:
        fail(PROG, f"cannot open a zenoh session to {', '.join(endpoints)}: {short_error(exc)}")
    stop_requested = stop_on_signals()
    print(f"{PROG}: recording {key_expression(sysid)} from {', '.join(endpoints)} to {out}; Ctrl-C stops",
          file=sys.stderr, flush=True)  # fmt: skip
    start = time.monotonic()
    recorded = counter("recorded", "samples", disable=args.no_progress)
    try:
        while not stop_requested() and (args.duration is None or time.monotonic() - start < args.duration):
            time.sleep(0.05)
            advance_to(recorded, sum(recorder.counts.values()))
    finally:
        recorded.close()
    try:
        counts = recorder.stop()
    except OSError as exc:
        print(f"{PROG}: error: writing {out} failed: {exc.strerror or exc} ({sum(recorder.counts.values())} samples "
              "received)", file=sys.stderr)  # fmt: skip
        return FAILED
    for key in sorted(counts):
        errors = recorder.errors.get(key, 0)
        print(f"{key}: {counts[key]}" + (f" ({errors} undecodable)" if errors else ""))
    total = sum(counts.values())
    print(f"{PROG}: {total} samples in {out}", file=sys.stderr)
    if total == 0:
        print(f"{PROG}: error: nothing received: is a vehicle publishing on {', '.join(endpoints)}?", file=sys.stderr)
        return FAILED
    return OK
