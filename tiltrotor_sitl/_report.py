"""What a failed test's report says of each of its vehicles (the pytest plugin's section): where its files are,
what it last said of itself, where the plant last had it, and the last lines both processes said on stderr."""

from __future__ import annotations

from pathlib import Path

from tiltrotor_sitl import VehicleError, VehicleHandle
from tiltrotor_sitl.truth import TruthTimeout

STDERR_LINES = 15


def vehicle_report(vehicle: VehicleHandle) -> str:
    """The report's section for `vehicle` (started; its processes may have ended)."""
    lines = [f"folder: {vehicle.folder}"]
    lines += [f"  {path}" for path in _files(vehicle.folder)]
    lines += [f"ULog: {path}" for path in vehicle.logs()]
    if vehicle.tlog_path.is_file():
        lines.append(f"ground station's MAVLink log: {vehicle.tlog_path}")
    lines.append(f"status: {vehicle.status()}")
    lines.append(f"truth: {_truth(vehicle)}")
    for process in vehicle.process_names:
        running = (
            "running" if vehicle.process(process).poll() is None else f"exit code {vehicle.process(process).poll()}"
        )
        lines.append(f"--- {process} ({running}), last {STDERR_LINES} lines of stderr ---")
        lines.append(vehicle.stderr_tail(process, STDERR_LINES) or "(nothing)")
    return "\n".join(lines)


def _files(folder: Path) -> list[Path]:
    try:
        return sorted(path for path in folder.rglob("*") if path.is_file())
    except OSError:
        return []


def _truth(vehicle: VehicleHandle) -> str:
    try:
        last = vehicle.truth.latest(timeout_s=0.0)
    except VehicleError:
        return "not recorded (started without truth)"
    except TruthTimeout:
        return "no sample received"
    north, east, down = last.position_ned
    return (
        f"t = {last.t:.3f} s, NED ({north:.2f}, {east:.2f}, {down:.2f}) m, altitude {last.altitude:.2f} m, "
        f"{'on the ground' if last.on_ground else 'in the air'}; {len(vehicle.truth)} samples recorded"
    )
