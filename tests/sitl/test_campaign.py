"""`vtol campaign` (issue 14): campaign files and their refusals, points and keys, the scenario variants, the
store, and a small campaign flown on a local Dask cluster of 2 workers, killed halfway and resumed."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from importlib import resources
from pathlib import Path

import duckdb
import psutil
import pytest

from ground_tools.metrics import detection_time
from tests.unit.test_campaign import _campaign

pytestmark = pytest.mark.timeout(600)

SMALL = """
scenario = "servo-failure"
controllers = ["mpc", "pid"]
[fixed]
duration_s = 0.6
SIH_WIND_E = -0.5
plant_airframe = "paper.toml"
[axes]
jam_deg = [0, 60]
jam_speed_mps = [0.1, 0.3]
"""


# ---- a real campaign ----------------------------------------------------------------------------------------------
def _session_processes(session: int) -> list[psutil.Process]:
    alive = []
    for process in psutil.process_iter():
        try:
            if os.getsid(process.pid) == session and process.status() != psutil.STATUS_ZOMBIE:
                alive.append(process)
        except (ProcessLookupError, psutil.Error):
            continue
    return alive


def _vtol_campaign(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "ground_tools", "campaign", *args], capture_output=True, text=True,
                          timeout=400)  # fmt: skip


def test_a_campaign_on_two_workers_is_killed_resumed_and_reported(tmp_path: Path) -> None:
    file, out = _campaign(tmp_path, SMALL), tmp_path / "out"
    paper = resources.files("aircraft.airframes").joinpath("chen2024_tiltrotor.toml").read_text()
    (tmp_path / "paper.toml").write_text(paper)  # the plant's own copy: an airframe file given to the plant alone
    args = [str(file), "--out", str(out), "--workers", "2", "--no-progress"]
    first = subprocess.Popen([sys.executable, "-m", "ground_tools", "campaign", *args], stderr=subprocess.PIPE,
                             stdout=subprocess.DEVNULL, text=True, start_new_session=True)  # fmt: skip
    try:
        stored = 0
        for line in first.stderr:
            stored += "stored" in line
            if stored == 3:
                break
    finally:
        os.killpg(first.pid, signal.SIGKILL)  # the driver, its Dask workers and their flights' processes
        first.wait()
        first.stderr.close()
    assert stored == 3
    while _session_processes(first.pid):
        time.sleep(0.1)
    with duckdb.connect(str(out / "campaign.duckdb"), read_only=True) as db:
        before = dict(db.execute("SELECT key, finished_utc FROM flights WHERE status = 'done'").fetchall())
    assert len(before) >= 3

    resumed = _vtol_campaign(*args)
    assert resumed.returncode == 0, resumed.stderr
    assert f"8 flights, {len(before)} in the store, {8 - len(before)} to fly" in resumed.stderr
    assert resumed.stderr.count("stored") == 8 - len(before)
    with duckdb.connect(str(out / "campaign.duckdb"), read_only=True) as db:
        frame = db.execute("SELECT * FROM flights").df()
    assert len(frame) == 8 and set(frame["status"]) == {"done"} and frame["key"].is_unique
    assert {k: v for k, v in zip(frame["key"], frame["finished_utc"]) if k in before} == before  # not flown again
    assert sorted(frame["controller"]) == ["mpc"] * 4 + ["pid"] * 4
    assert set(zip(frame["jam_deg"], frame["jam_speed_mps"])) == {(0.0, 0.1), (0.0, 0.3), (60.0, 0.1), (60.0, 0.3)}
    assert frame["survived"].all() and frame["code_version"].str.len().min() > 0
    for _, row in frame.iterrows():
        assert row["failure_trigger"] == f"ground speed reaches {row['jam_speed_mps']:g} m/s"
        assert row["failure_t_s"] is not None and 0.0 < row["failure_t_s"] < 0.6
        metrics = json.loads((Path(row["run_dir"]) / "metrics.json").read_text())
        assert metrics["vx_rmse"] == row["vx_rmse"] and metrics["survived"] == row["survived"]
        run = json.loads((Path(row["run_dir"]) / "run.json").read_text())
        assert f"STUCK at {row['jam_deg']:.1f} deg" in json.dumps(run["statustexts"])
        found = detection_time(run["statustexts"], row["failure_t_s"])  # within 0.6 s, or not yet
        assert (
            math.isnan(row["detected_after_s"])
            if found is None
            else row["detected_after_s"] == found - row["failure_t_s"]
        )
        assert run["plant"]["wind_ned"] == [0.0, 0.5, 0.0] and row["SIH_WIND_E"] == -0.5
        assert Path(run["plant"]["airframe"]).resolve() == (tmp_path / "paper.toml").resolve()
    survival = out / "figures" / "survival.png"
    assert survival.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and (out / "figures" / "error.png").is_file()
    report = (out / "report.md").read_text()
    assert "Flights: 8 planned, 8 in the store, 8 flown, 0 failed" in report and "figures/survival.png" in report
    assert report.count("The failure was found in ") == 2  # a sentence per controller, from detected_after_s

    survival.unlink()
    again = _vtol_campaign(*args[:3], "--report")
    assert again.returncode == 0, again.stderr
    assert survival.is_file() and "to fly" not in again.stderr
    with duckdb.connect(str(out / "campaign.duckdb"), read_only=True) as db:
        assert db.execute("SELECT count(*) FROM flights").fetchone()[0] == 8


LONG = """
scenario = "accel"
controllers = ["mpc", "pid"]
[fixed]
duration_s = 30.0
[axes]
SIH_WIND_N = [0, 1, 2]
"""


def _alive(pid: int) -> bool:
    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def _mentioning(text: str) -> list[int]:
    """The running processes whose command line mentions `text` (a flight's autopilot names its run folder)."""
    found = []
    for process in psutil.process_iter(["cmdline"]):
        try:
            if text in " ".join(process.info["cmdline"] or ()) and process.status() != psutil.STATUS_ZOMBIE:
                found.append(process.pid)
        except psutil.Error:
            continue
    return found


def _family(pids: set[int]) -> set[int]:
    """`pids` and the children of those still running (a worker may start a flight as the command dies)."""
    found = set(pids)
    for pid in pids:
        try:
            found |= {child.pid for child in psutil.Process(pid).children(recursive=True)}
        except psutil.Error:
            continue
    return found


def _cmdline(process: psutil.Process) -> str:
    try:
        return " ".join(process.cmdline())
    except psutil.Error:
        return ""


def test_a_campaign_killed_by_sigkill_mid_flight_leaves_no_process_behind(tmp_path: Path) -> None:
    """Only the command's process is killed (not its process group): its Dask workers and their flights' plants
    and autopilots end by themselves, checked by PID."""
    file, out = _campaign(tmp_path, LONG), tmp_path / "out"
    command = subprocess.Popen([sys.executable, "-m", "ground_tools", "campaign", str(file), "--out", str(out),
                                "--workers", "2", "--no-progress"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
    seen: set[int] = {command.pid}
    try:
        deadline = time.monotonic() + 300
        flying: list[str] = []
        while len(flying) < 4 and time.monotonic() < deadline and command.poll() is None:
            family = psutil.Process(command.pid).children(recursive=True)
            seen |= {process.pid for process in family}
            flying = [line for line in map(_cmdline, family) if " -m sim_bridge " in line or " -m autopilot " in line]
            time.sleep(0.1)
        assert len(flying) == 4, f"not two flights (plant and autopilot each) flying: {flying}"
    finally:
        os.kill(command.pid, signal.SIGKILL)
        command.wait()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        seen = _family(seen)
        if not any(_alive(pid) for pid in seen) and not _mentioning(str(out)):
            break
        time.sleep(0.1)
    left = [(pid, _cmdline(psutil.Process(pid))) for pid in seen if _alive(pid)]
    assert left == [] and _mentioning(str(out)) == []
    assert len(seen) >= 1 + 2 + 4  # the command, its two workers and two flights' processes were checked
