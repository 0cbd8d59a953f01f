"""Command-line conventions shared by vtol-sim, vtol-autopilot and vtol (docs/mavlink.md).

Bad arguments give exactly one line on stderr, "<prog>: error: <what>", and exit code 2.
"""

from __future__ import annotations

import argparse
import ipaddress
import math
import signal
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

from transport.link_signing import KeyFileRefused, read_key_file


class OneLineArgumentParser(argparse.ArgumentParser):
    """argparse with a one-line error (no usage dump) and exit code 2, and --version (each subcommand too)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.add_argument("--version", action=VersionAction, help="print the version and exit")

    def error(self, message: str) -> NoReturn:
        print(f"{self.prog}: error: {message}", file=sys.stderr)
        raise SystemExit(2)


class VersionAction(argparse.Action):
    """--version: "<prog> <version>" on stdout, exit 0 (the version looked up only when asked: importlib.metadata
    costs every start-up 17 ms)."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS, help: str | None = None) -> None:
        super().__init__(option_strings, dest=dest, default=argparse.SUPPRESS, nargs=0, help=help)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> NoReturn:  # fmt: skip
        print(f"{parser.prog} {package_version()}")
        parser.exit()


def package_version() -> str:
    """The installed tiltrotor-sitl's version."""
    import importlib.metadata

    try:
        return importlib.metadata.version("tiltrotor-sitl")
    except importlib.metadata.PackageNotFoundError:
        return "(not installed: run from a source tree)"


def fail(prog: str, message: str) -> NoReturn:
    """Refuse a run for a reason found after parsing (broken file, port in use)."""
    print(f"{prog}: error: {message}", file=sys.stderr)
    raise SystemExit(2)


def key_file_option(prog: str, option: str, path: str | None) -> bytes | None:
    """The signing key in the file an option names (None without the option), or the run refused in one line."""
    if path is None:
        return None
    try:
        return read_key_file(path)
    except KeyFileRefused as exc:
        fail(prog, f"{option} {exc}")


def writable_folder(prog: str, folder: Path) -> Path:
    """Create `folder` if needed and check that files can be written in it, or refuse the run in one line."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / ".write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as exc:
        fail(prog, f"cannot write to {folder}: {exc.strerror or exc}")
    return folder


def finite_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite: {text!r}")
    return value


def nonnegative_float(text: str) -> float:
    value = finite_float(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0: {text!r}")
    return value


def positive_float(text: str) -> float:
    value = finite_float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0: {text!r}")
    return value


def ipv4_address(text: str) -> str:
    """An argparse type for an IPv4 address in dotted form (127.0.0.1, 0.0.0.0, 192.168.1.5)."""
    try:
        return str(ipaddress.IPv4Address(text))
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an IPv4 address: {text!r}") from None


def bounded_int(low: int, high: int):
    """An argparse type for integers in [low, high]."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be in {low}..{high}: {text!r}")
        return value

    return parse


def float_triple(text: str) -> tuple[float, float, float]:
    """'a,b,c' -> three finite floats."""
    parts = text.split(",")
    if len(parts) != 3:
        raise argparse.ArgumentTypeError(f"expected three comma-separated numbers: {text!r}")
    a, b, c = (finite_float(part) for part in parts)
    return a, b, c


def stop_on_signals() -> Callable[[], bool]:
    """Install SIGINT/SIGTERM handlers that only record the request; returns `stop_requested()` for the loop."""
    received: list[int] = []
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda number, frame: received.append(number))
    return lambda: bool(received)
