"""`vtol campaign` (issue 14): campaign files and their refusals, points and keys, the scenario variants, the
store, and a small campaign flown on a local Dask cluster of 2 workers, killed halfway and resumed."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import duckdb
import numpy as np
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
    ('scenario = "circle"\n[fixed]\nwind_d_mps = 90', "wind_d_mps = 90 is outside"),
    ('scenario = "circle"\n[fixed]\nwind_n_mps = 1', "wind_n_mps: the mean wind is SIH_WIND_N"),
    ('scenario = "circle"\n[fixed]\nSIH_WIND_N = 90', "SIH_WIND_N: 90 outside -40..40"),
    ('scenario = [', "is not TOML"),
    ('scenario = "circle"\n[report]\nerror = "radial_mean_m"',
     "report.error = 'radial_mean_m' is not a metric the error map can show: one of vx_rmse,"),
    ('scenario = "circle"\n[report]\nerror = "survived"', "report.error = 'survived' is not a metric"),
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
        main(
            [
                "campaign",
                str(_campaign(tmp_path, 'scenario = "accel"')),
                "--out",
                str(tmp_path / "out"),
                "--address",
                "nonsense",
            ]
        )
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
    options = build_sim_parser().parse_args(argv[argv.index("sim_bridge") + 1 :])  # (a leading minus is no option)
    assert options.wind == (-2.0, 0.5, -1.0) and options.airframe == "other.toml"
    assert not any(arg.startswith("--wind") for arg in SimCommand().argv())


def test_the_same_key_twice_is_one_row(tmp_path: Path) -> None:
    store = ResultStore(tmp_path / "s.duckdb")
    row = {
        "key": "k1",
        "scenario": "accel",
        "controller": "mpc",
        "repetition": 0,
        "params": {"duration_s": 1.0},
        "status": "done",
        "metrics": {"survived": True, "vx_rmse": 0.5, "t_reach_s": float("nan")},
    }
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
    store.put(
        "c",
        {
            "key": "k1",
            "scenario": "accel",
            "controller": "mpc",
            "repetition": 0,
            "params": {},
            "status": "done",
            "metrics": {"vx_rmse": 0.5, "heading_error_max_deg": 2.5},
        },
    )
    frame = store.frame().set_index("key")
    store.close()
    assert frame.loc["k1", "heading_error_max_deg"] == 2.5 and np.isnan(frame.loc["k0", "heading_error_max_deg"])
    assert frame.loc["k0", "vx_rmse"] == 0.3


def test_without_the_campaign_extra_the_command_names_it_in_one_line(tmp_path: Path, capsys, monkeypatch) -> None:
    """A Python without Dask (the extra not installed): sys.modules holds None for it, so importing it fails as a
    missing package does; the campaign's own modules are imported afresh."""
    for module in [name for name in sys.modules if name.startswith("ground_tools.campaign.")]:
        monkeypatch.delitem(sys.modules, module)
    for missing in ("dask", "dask.distributed", "distributed"):
        monkeypatch.setitem(sys.modules, missing, None)
    with pytest.raises(SystemExit) as exit_:
        main(["campaign", str(_campaign(tmp_path, 'scenario = "accel"'))])
    error = capsys.readouterr().err
    assert exit_.value.code == 2 and error.count("\n") == 1, error
    assert "vtol campaign: error: needs dask" in error and "pip install 'tiltrotor-sitl[campaign]'" in error
