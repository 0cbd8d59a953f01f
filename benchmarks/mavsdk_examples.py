"""MAVSDK-Python's own examples, each run unmodified against a fresh `vtol up` on the default ports.

    python benchmarks/mavsdk_examples.py EXAMPLES_DIR [--only NAME ...] [--results FILE] [--timeout S]

EXAMPLES_DIR is a folder of MAVSDK-Python's examples (its `examples/`, with example-mission.plan); they are not
part of this repository. Each example runs with MAVSDK 3.x (`mavsdk<4`, which bundles its mavsdk_server) from a
separate venv (--mavsdk-venv; made with pip if it is missing), in a scratch copy of the folder, against a `vtol up`
started for it alone with its own state folder (parameters, mission, fence and rally), so nothing an earlier
example stored is kept. A passive listener on the GCS port (14550) follows HEARTBEAT and EXTENDED_SYS_STATE.

An example passes when it exits 0 within the time-out and prints no error (a traceback, "Error:", "failed with",
"error code"). goto.py and manual_control.py loop for ever after their last action, by design: they pass when they
reached that loop with no error and the vehicle is still flying (armed, in the air) when the time is up; the output
says so. With --results FILE the outcomes are merged into FILE (JSON, by example), so the examples can be run in
pieces; the summary line counts every example of the folder: "N of M pass".
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from pymavlink import mavutil

from transport.mavlink import mavlink as M

GCS_LISTEN = "udpin:127.0.0.1:14550"  # where `vtol up` sends its GCS link until a ground station speaks
ERROR_PATTERN = re.compile(r"Traceback|failed +with|[Ee]rror code|Error:")
LOOPS_FOREVER = {  # example: what it prints once it has reached its endless loop (None: its last action's line)
    "goto": "Staying connected, press Ctrl-C to exit",
    "manual_control": "-- Starting manual control",
}
READY_TIMEOUT_S = 30.0
STOP_TIMEOUT_S = 10.0


@dataclass
class Outcome:
    name: str
    passed: bool
    note: str
    seconds: float


class VehicleListener:
    """Listens to the GCS link: is the vehicle armed and in the air now."""

    def __init__(self) -> None:
        self.connection = mavutil.mavlink_connection(GCS_LISTEN, source_system=255)
        self.heartbeats = 0
        self.armed = False
        self.landed_state = M.MAV_LANDED_STATE_UNDEFINED
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._listen, daemon=True)
        self._thread.start()

    def _listen(self) -> None:
        while not self._stop.is_set():
            message = self.connection.recv_match(type=["HEARTBEAT", "EXTENDED_SYS_STATE"], blocking=True, timeout=0.2)
            if message is None or message.get_srcComponent() != 1:
                continue
            if message.get_type() == "HEARTBEAT":
                self.heartbeats += 1
                self.armed = bool(message.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED)
            else:
                self.landed_state = message.landed_state

    @property
    def flying(self) -> bool:
        return self.armed and self.landed_state == M.MAV_LANDED_STATE_IN_AIR

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self.connection.close()


def mavsdk_python(venv: Path) -> Path:
    """The venv's python with MAVSDK 3.x (installed with pip if the venv is not there yet)."""
    python = venv / "bin" / "python"
    if not python.exists():
        subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
        subprocess.run([str(venv / "bin" / "pip"), "install", "-q", "mavsdk<4"], check=True)
    return python


def vtol_command() -> str:
    found = shutil.which("vtol") or str(Path(sys.executable).parent / "vtol")
    if not Path(found).exists():
        sys.exit("mavsdk_examples: no `vtol` found (install the project first)")
    return found


def stop(process: subprocess.Popen) -> None:
    """Ctrl-C to the process group of `vtol up` (as a terminal would), then a kill if it does not end."""
    try:
        os.killpg(process.pid, signal.SIGINT)
        process.wait(STOP_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    except ProcessLookupError:
        process.wait()


def judge(name: str, returncode: int | None, output: str, flying: bool) -> tuple[bool, str]:
    """Pass or not, and why; `returncode` None: the time-out ended it."""
    lines = output.strip().splitlines()
    last = lines[-1][:160] if lines else "(no output)"
    error = ERROR_PATTERN.search(output)
    if error is not None:
        line = next(line for line in lines if ERROR_PATTERN.search(line))
        return False, f"error: {line.strip()[:160]}"
    marker = LOOPS_FOREVER.get(name)
    if returncode is None:
        if marker is None:
            return False, f"time-out; last line: {last}"
        if marker not in output:
            return False, f"time-out before its endless loop; last line: {last}"
        if not flying:
            return False, "reached its endless loop, but the vehicle was not flying at the time-out"
        return True, "loops for ever by design: reached its loop with no error, still flying at the time-out"
    if returncode != 0:
        return False, f"exit code {returncode}; last line: {last}"
    return True, "ran to its end"


def run_example(name: str, work: Path, python: Path, vtol: str, timeout_s: float) -> Outcome:
    started = time.monotonic()
    state = Path(tempfile.mkdtemp(prefix=f"state-{name}-", dir=work))  # parameters, missions: fresh for each
    with open(work / f"{name}.vtol.log", "w") as log:
        up = subprocess.Popen([vtol, "up", "--params", str(state / "params.json")], stdout=log, stderr=log,
                              start_new_session=True)  # fmt: skip
    listener = VehicleListener()
    try:
        deadline = time.monotonic() + READY_TIMEOUT_S
        while listener.heartbeats == 0 and time.monotonic() < deadline and up.poll() is None:
            time.sleep(0.2)
        if listener.heartbeats == 0:
            return Outcome(name, False, "vtol up sent no HEARTBEAT (see its log)", time.monotonic() - started)
        flying = False
        time.sleep(1.0)  # the vehicle's state from the plant, as a user starting a script after `vtol up` has it
        with open(work / f"{name}.out", "w") as out:
            example = subprocess.Popen([str(python), f"{name}.py"], cwd=work, stdout=out, stderr=subprocess.STDOUT,
                                       start_new_session=True)  # fmt: skip
            try:
                returncode: int | None = example.wait(timeout_s)
            except subprocess.TimeoutExpired:
                returncode = None
                flying = listener.flying
                os.killpg(example.pid, signal.SIGKILL)
                example.wait()
        output = (work / f"{name}.out").read_text(errors="replace")
        passed, note = judge(name, returncode, output, flying)
        return Outcome(name, passed, note, time.monotonic() - started)
    finally:
        listener.close()
        stop(up)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("examples", type=Path, help="a folder of MAVSDK-Python's examples")
    parser.add_argument("--only", nargs="+", metavar="NAME", help="run these examples (names without .py)")
    parser.add_argument("--results", type=Path, help="merge the outcomes into this JSON file (runs in pieces)")
    parser.add_argument("--timeout", type=float, default=150.0, help="seconds per example (default 150)")
    parser.add_argument("--mavsdk-venv", type=Path, default=Path(tempfile.gettempdir()) / "mavsdk3-venv",
                        help="a venv with mavsdk<4 (made if missing)")  # fmt: skip
    args = parser.parse_args(argv)
    folder: Path = args.examples
    names = sorted(path.stem for path in folder.glob("*.py"))
    if not names:
        parser.error(f"no examples (*.py) in {folder}")
    unknown = sorted(set(args.only or ()) - set(names))
    if unknown:
        parser.error(f"not in {folder}: {', '.join(unknown)}")
    python = mavsdk_python(args.mavsdk_venv)
    vtol = vtol_command()
    work = Path(tempfile.mkdtemp(prefix="mavsdk-examples-"))
    for path in folder.iterdir():
        if path.is_file():
            shutil.copy(path, work / path.name)
    results: dict[str, dict] = {}
    if args.results is not None and args.results.exists():
        results = json.loads(args.results.read_text())
    for name in args.only or names:
        outcome = run_example(name, work, python, vtol, args.timeout)
        results[name] = asdict(outcome)
        print(
            f"{'pass' if outcome.passed else 'FAIL'}  {name:34s} {outcome.seconds:5.0f} s  {outcome.note}", flush=True
        )
        if args.results is not None:
            args.results.write_text(json.dumps(results, indent=1) + "\n")
    passed = sum(1 for name in names if results.get(name, {}).get("passed"))
    missing = [name for name in names if name not in results]
    print(f"logs in {work}")
    print(f"MAVSDK-Python examples: {passed} of {len(names)} pass"
          + (f" ({len(missing)} not run yet: {' '.join(missing)})" if missing else ""))  # fmt: skip
    return 0 if passed == len(names) else 1


if __name__ == "__main__":
    sys.exit(main())
