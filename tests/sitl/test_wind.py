"""The simulated wind through the processes (docs/plant-link.md, "Wind"): the plant's wind shown among the
autopilot's parameters and set in flight by a ground station's PARAM_SET; a gusty flight (Dryden turbulence) that
repeats bit for bit with the same seed and differs with another, flown as a campaign."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import duckdb

from tests.sitl.ground_station import GroundStation
from tests.sitl.test_mavlink_failsafes import set_param
from tiltrotor_sitl import Vehicle, Wind


def read_param(gs: GroundStation, name: str) -> float:
    asked = len(gs.param_values)
    gs.conn.mav.param_request_read_send(gs.vehicle, 1, name.encode(), -1)
    gs.wait(lambda: any(p.param_id == name for p in gs.param_values[asked:]), name)
    return next(p for p in gs.param_values[asked:] if p.param_id == name).param_value


def test_a_ground_station_sees_the_plants_wind_and_changes_it_in_flight(tmp_path):
    with Vehicle(spawn_alt=30.0, speed=None, truth=False, wind=Wind(4.0, 90.0), folder=tmp_path) as vehicle:
        gs = GroundStation(vehicle.gcs_port, vehicle.sysid)
        try:
            gs.connect()
            assert read_param(gs, "SIM_WIND_SPD") == 4.0 and read_param(gs, "SIM_WIND_DIR") == 90.0
            gs.wait(lambda: "VFR_HUD" in gs.latest and abs(gs.latest["VFR_HUD"].airspeed - 4.0) < 0.3,
                    "the plant's 4 m/s in the airspeed")  # fmt: skip
            set_param(gs, "SIM_WIND_DIR", 270.0)  # 4 m/s from the west, then 18
            set_param(gs, "SIM_WIND_SPD", 18.0)
            gs.wait(lambda: any("wind 18 m/s from 270 deg" in text for text in gs.statustexts), "the plant's text")
            changed = gs.sim_time
            with gs.recording("LOCAL_POSITION_NED", "VFR_HUD") as samples:
                gs.wait_sim(20.0)
            drift = max(math.hypot(m.x, m.y) for m in samples if m.get_type() == "LOCAL_POSITION_NED")
            airspeeds = [m.airspeed for m in samples if m.get_type() == "VFR_HUD"][-50:]  # the last 5 s
            mean_airspeed = sum(airspeeds) / len(airspeeds)
            print(f"over the last 5 of {gs.sim_time - changed:.1f} s: airspeed {mean_airspeed:.2f} m/s (from "
                  f"{min(airspeeds):.2f} to {max(airspeeds):.2f}); at most {drift:.2f} m from the spawn")  # fmt: skip
            assert abs(mean_airspeed - 18.0) < 1.5 and drift < 20.0  # blown off by the step, held in the wind
            assert read_param(gs, "SIM_WIND_SPD") == 18.0
        finally:
            gs.close()
        assert "SIM_WIND" not in vehicle.params_path.read_text() if vehicle.params_path.exists() else True
        assert "wind 18 m/s from 270 deg" in vehicle.stderr("vtol-sim")


GUSTS = """scenario = "accel"
controllers = ["mpc"]
repetitions = 2
[fixed]
duration_s = 3.0
SIM_WIND_SPD = 6.0
SIM_WIND_DIR = 90.0
SIM_WIND_TURB = 2.0
[axes]
SIM_WIND_SEED = [1, 2]
"""


def test_a_gusty_flight_repeats_bit_for_bit_with_its_seed_and_differs_with_another(tmp_path: Path) -> None:
    (tmp_path / "gusts.toml").write_text(GUSTS)
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "ground_tools", "campaign", str(tmp_path / "gusts.toml"), "--out",
                           str(out), "--workers", "1", "--no-progress"], capture_output=True, text=True,
                          timeout=500)  # fmt: skip
    assert done.returncode == 0, done.stderr
    with duckdb.connect(str(out / "campaign.duckdb"), read_only=True) as db:
        rows = db.execute("SELECT SIM_WIND_SEED, repetition, run_dir FROM flights WHERE status = 'done'").fetchall()
    assert len(rows) == 4
    series = {
        (int(seed), repetition): (Path(run_dir) / "timeseries.csv").read_bytes() for seed, repetition, run_dir in rows
    }
    assert series[(1, 0)] == series[(1, 1)] and series[(2, 0)] == series[(2, 1)]
    assert series[(1, 0)] != series[(2, 0)]
    calm_lines = series[(1, 0)].splitlines()
    print(
        f"{len(calm_lines)} rows each; seed 1 and seed 2 differ from row "
        f"{next(i for i, (a, b) in enumerate(zip(calm_lines, series[(2, 0)].splitlines())) if a != b)}"
    )
