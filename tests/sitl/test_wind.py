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


HELD_M = 5.0  # east of its place, when it has fought the new wind back
RETURN_S = 90.0  # simulated seconds it may take


def test_a_ground_station_sees_the_plants_wind_and_changes_it_in_flight(tmp_path):
    """Hovering in Hold in a wind from the north; a ground station turns it into a 14 m/s wind from the west by
    PARAM_SET: the vehicle is blown east and flies back to its place, with the wind in its airspeed (the paper's
    aerodynamics fade in from 10 m/s, so a weaker wind barely pushes it; at 18 m/s, the cruise speed, the wind can
    overpower the hover's yaw and turn the vehicle, docs/plant-link.md). How it leans when the window ends depends
    on where it is on its way back (the PARAM_SET lands at a wall-clock moment), so the lean is printed, not checked."""
    with Vehicle(spawn_alt=30.0, speed=0, truth=False, wind=Wind(from_north=4.0), folder=tmp_path) as vehicle:
        gs = GroundStation(vehicle.gcs_port, vehicle.sysid)
        try:
            gs.connect()
            assert read_param(gs, "SIH_WIND_N") == 4.0 and read_param(gs, "SIH_WIND_E") == 0.0
            gs.wait(lambda: "VFR_HUD" in gs.latest and abs(gs.latest["VFR_HUD"].airspeed - 4.0) < 0.3,
                    "the plant's 4 m/s in the airspeed")  # fmt: skip
            with gs.recording("LOCAL_POSITION_NED") as calm:
                gs.wait_sim(5.0)
            set_param(gs, "SIH_WIND_N", 0.0)
            set_param(gs, "SIH_WIND_E", -14.0)  # from the west: blowing east
            gs.wait(lambda: any("wind from N 0 E -14, gusts 0 m/s" in text for text in gs.statustexts),
                    "the plant's text")  # fmt: skip
            with gs.recording("LOCAL_POSITION_NED", "VFR_HUD", "ATTITUDE") as samples:
                # Blown east, then back: how far and how fast depends on where the PARAM_SET lands in the hover (a
                # wall-clock moment); within RETURN_S of simulated time it is back within HELD_M of its place.
                start_s = gs.sim_time
                gs.wait_sim(5.0)
                gs.wait(lambda: abs(gs.latest["LOCAL_POSITION_NED"].y) < HELD_M or gs.sim_time - start_s > RETURN_S,
                        "back near its place or the time up", timeout_s=300)  # fmt: skip
            east = [m.y for m in samples if m.get_type() == "LOCAL_POSITION_NED"]
            calm_east = [m.y for m in calm]
            rolls = [math.degrees(m.roll) for m in samples if m.get_type() == "ATTITUDE"][-50:]  # the last second
            airspeeds = [m.airspeed for m in samples if m.get_type() == "VFR_HUD"][-50:]  # the last 5 s
            mean_airspeed, mean_roll = sum(airspeeds) / len(airspeeds), sum(rolls) / len(rolls)
            print(f"east drift: calm {min(calm_east):.2f} .. {max(calm_east):.2f} m, in the new wind "
                  f"{min(east):.2f} .. {max(east):.2f} m, {east[-1]:.2f} m at the end; airspeed {mean_airspeed:.2f} "
                  f"m/s, roll {mean_roll:.1f} deg")  # fmt: skip
            assert max(east) - max(calm_east) > 0.3  # blown downwind, east
            assert abs(east[-1]) < HELD_M, f"not back within {RETURN_S:g} simulated s"  # and held again
            assert abs(mean_airspeed - 14.0) < 3.0  # the new wind, felt (plus its own speed back into it)
            assert read_param(gs, "SIH_WIND_E") == -14.0
        finally:
            gs.close()
        assert "SIH_WIND" not in (vehicle.params_path.read_text() if vehicle.params_path.exists() else "")
        assert "wind from N 0 E -14, gusts 0 m/s" in vehicle.stderr("vtol-sim")


GUSTS = """scenario = "accel"
controllers = ["mpc"]
repetitions = 2
[fixed]
duration_s = 3.0
SIH_WIND_E = 6.0
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
