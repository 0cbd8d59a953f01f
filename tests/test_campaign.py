"""`vtol campaign` (issue 14): campaign files and their refusals, points and keys, the scenario variants, the
store, and a small campaign flown on a local Dask cluster of 2 workers, killed halfway and resumed."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from importlib import resources
from pathlib import Path

import duckdb
import numpy as np
import psutil
import pytest

from ground_tools.campaign.points import campaign_points
from ground_tools.campaign.spec import CampaignError, flight_count, load_campaign
from ground_tools.campaign.store import COLUMNS, ResultStore
from ground_tools.cli import main
from scenarios.experiments import SCENARIOS
from scenarios.profiles import CircleProfile, circle, circle_duration
from scenarios.variants import VariantError, build_scenario
from sim_bridge.cli import build_parser as build_sim_parser
from tiltrotor_sitl._commands import SimCommand

pytestmark = pytest.mark.timeout(600)

SMALL = """
scenario = "servo-failure"
controllers = ["mpc", "pid"]
[fixed]
duration_s = 0.6
wind_e_mps = 0.5
plant_airframe = "paper.toml"
[axes]
jam_deg = [0, 60]
jam_speed_mps = [0.1, 0.3]
"""


def _campaign(tmp_path: Path, text: str, name: str = "small") -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


# ---- files, points, variants ------------------------------------------------------------------------------------
def test_grid_and_seeded_samples_give_stable_keys(tmp_path: Path) -> None:
    text = """scenario = "motor-failure"
controllers = ["mpc"]
repetitions = 2
seed = 7
samples = 3
[fixed]
turns = 0.5
[axes]
radius_m = [100, 100.0, 200]
speed_mps = { from = 18, to = 30, steps = 3 }
failure_yaw_deg = { uniform = [30, 300] }
"""
    spec = load_campaign(_campaign(tmp_path, text))
    points = campaign_points(spec)
    assert flight_count(spec) == 1 * 2 * 3 * 3 * 3 and len(points) == 2 * 3 * 3 * 2  # 100 and 100.0: one point
    assert [p.key for p in points] == [p.key for p in campaign_points(load_campaign(_campaign(tmp_path, text)))]
    assert len({p.key for p in points}) == len(points)
    assert sorted({p.params["speed_mps"] for p in points}) == [18.0, 24.0, 30.0]
    yaws = {p.params["failure_yaw_deg"] for p in points}
    assert len(yaws) == 3 and all(30 <= y <= 300 for y in yaws)
    reseeded = campaign_points(load_campaign(_campaign(tmp_path, text.replace("seed = 7", "seed = 8"))))
    assert {p.params["failure_yaw_deg"] for p in reseeded} != yaws


@pytest.mark.parametrize("text, message", [
    ('scenario = "loop"', "scenario: one of accel"),
    ('scenario = "accel"\n[axes]\nradius_m = [100]', "scenario 'accel' takes no parameter 'radius_m'"),
    ('scenario = "servo-failure"\n[axes]\njam_deg = [-20, 60]', "jam_deg = -20 is outside -7 .. 95"),
    ('scenario = "circle"\ncontrollers = ["lqr"]', "controllers: a list of distinct ones of mpc, pid"),
    ('scenario = "circle"\n[axes]\nradius_m = { uniform = [300, 100] }', "low must be below high"),
    ('scenario = "circle"\nspeed = 3', "unknown key(s) speed"),
    ('scenario = "circle"\n[fixed]\nplant_airframe = "nowhere.toml"', "plant_airframe 'nowhere.toml': no such file"),
    ('scenario = "circle"\n[fixed]\nwind_n_mps = 90', "wind_n_mps = 90 is outside"),
    ('scenario = [', "is not TOML"),
])  # fmt: skip
def test_bad_campaign_files_are_refused_in_one_line(tmp_path: Path, capsys, text: str, message: str) -> None:
    with pytest.raises(CampaignError, match=None):
        load_campaign(_campaign(tmp_path, text))
    with pytest.raises(SystemExit) as exit_:
        main(["campaign", str(_campaign(tmp_path, text)), "--out", str(tmp_path / "out")])
    error = capsys.readouterr().err
    assert exit_.value.code == 2 and message in error and error.count("\n") == 1, error


def test_a_cluster_address_dask_cannot_read_is_refused_in_one_line(tmp_path: Path, capsys) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["campaign", str(_campaign(tmp_path, 'scenario = "accel"')), "--out", str(tmp_path / "out"),
              "--address", "nonsense"])
    error = capsys.readouterr().err
    assert exit_.value.code == 2 and "cannot start or reach the cluster at nonsense" in error, error


def test_the_paper_experiments_are_the_variants_at_the_paper_values() -> None:
    for name in SCENARIOS:
        assert build_scenario(name, {}) is SCENARIOS[name]
    paper = CircleProfile()
    for t in np.linspace(0.0, circle_duration(), 97):
        assert np.array_equal(paper(float(t)), circle(float(t)))
    variant = build_scenario("motor-failure", {"radius_m": 150.0, "speed_mps": 20.0, "failure_yaw_deg": 45.0})
    assert variant.circle.radius == 150.0 and variant.circle.start_s == 10.0
    assert variant.duration_s == pytest.approx(10.0 + 2 * np.pi * 150.0 / 20.0, abs=0.01)
    assert variant.failure.trigger == "yaw reaches 45 deg" and variant.failure.injection.instance == 1
    jam = build_scenario("servo-failure", {"jam_deg": 5.0, "jam_speed_mps": 12.0})
    assert jam.failure.injection.value == 5.0 and jam.failure.trigger == "ground speed reaches 12 m/s"
    with pytest.raises(VariantError, match="rotor must be a whole number"):
        build_scenario("motor-failure", {"rotor": 1.5})


def test_wind_and_airframe_reach_the_plants_command_line() -> None:
    argv = SimCommand(wind_ned=(-2.0, 0.5, -1.0), airframe=Path("other.toml")).argv()
    options = build_sim_parser().parse_args(argv[argv.index("sim_bridge") + 1:])  # (a leading minus is no option)
    assert options.wind == (-2.0, 0.5, -1.0) and options.airframe == "other.toml"
    assert not any(arg.startswith("--wind") for arg in SimCommand().argv())


def test_the_same_key_twice_is_one_row(tmp_path: Path) -> None:
    store = ResultStore(tmp_path / "s.duckdb")
    row = {"key": "k1", "scenario": "accel", "controller": "mpc", "repetition": 0, "params": {"duration_s": 1.0},
           "status": "done", "metrics": {"survived": True, "vx_rmse": 0.5, "t_reach_s": float("nan")}}
    store.put("c", row)
    store.put("c", {**row, "metrics": {"survived": False, "vx_rmse": 0.7}})
    frame = store.frame()
    store.close()
    assert len(frame) == 1 and frame["vx_rmse"][0] == 0.7 and not frame["survived"][0]
    assert frame["duration_s"][0] == 1.0 and json.loads(frame["params"][0]) == {"duration_s": 1.0}


def test_a_store_written_before_a_metric_existed_gets_its_column(tmp_path: Path) -> None:
    path = tmp_path / "old.duckdb"
    old = duckdb.connect(str(path))
    columns = ", ".join(f'"{name}" {kind}' for name, kind in COLUMNS.items() if name != "heading_error_max_deg")
    old.execute(f"CREATE TABLE flights ({columns})")
    old.execute("INSERT INTO flights (key, status, vx_rmse) VALUES ('k0', 'done', 0.3)")
    old.close()
    store = ResultStore(path)
    store.put("c", {"key": "k1", "scenario": "accel", "controller": "mpc", "repetition": 0, "params": {},
                    "status": "done", "metrics": {"vx_rmse": 0.5, "heading_error_max_deg": 2.5}})
    frame = store.frame().set_index("key")
    store.close()
    assert frame.loc["k1", "heading_error_max_deg"] == 2.5 and np.isnan(frame.loc["k0", "heading_error_max_deg"])
    assert frame.loc["k0", "vx_rmse"] == 0.3


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
        assert run["plant"]["wind_ned"] == [0.0, 0.5, 0.0] and row["wind_e_mps"] == 0.5
        assert Path(run["plant"]["airframe"]).resolve() == (tmp_path / "paper.toml").resolve()
    survival = out / "figures" / "survival.png"
    assert survival.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and (out / "figures" / "error.png").is_file()
    report = (out / "report.md").read_text()
    assert "Flights: 8 planned, 8 in the store, 8 flown, 0 failed" in report and "figures/survival.png" in report

    survival.unlink()
    again = _vtol_campaign(*args[:3], "--report")
    assert again.returncode == 0, again.stderr
    assert survival.is_file() and "to fly" not in again.stderr
    with duckdb.connect(str(out / "campaign.duckdb"), read_only=True) as db:
        assert db.execute("SELECT count(*) FROM flights").fetchone()[0] == 8
