"""A tilt servo jammed far forward at low speed, flown by the MPC through the processes and MAVLink, the jam found by
the autopilot: differential tilt of the working rotors holds the yaw moment of the jammed rotor (docs/mpc.md, the
solver, failures), so the MPC keeps flying, with no failed solve and no fall-back to the PID (before, the aircraft
spun up and fell: the servo-jam campaign's 60 deg jam at 1 m/s); and with VT_MPC_Q_MOM_SRV set, the rotors' moment
bounded as for a rotor failure, it holds a rotor jammed past horizontal (95 deg at 9 m/s: lost with the default)."""

from __future__ import annotations

import json
from pathlib import Path

from ground_tools.scenario_run import run_scenario
from scenarios.variants import build_scenario


def test_the_mpc_holds_the_yaw_of_a_servo_jammed_at_60_deg_in_a_slow_hover(tmp_path: Path) -> None:
    scenario = build_scenario("servo-failure", {"servo": 1, "jam_deg": 60.0, "jam_speed_mps": 1.0, "duration_s": 6.0})
    result = run_scenario(scenario, "mpc", tmp_path, record=False)
    run = json.loads((result.run_dir / "run.json").read_text())
    assert run["failure"]["t_s"] < 1.0  # the jam came at 1 m/s, within the first second
    assert not any("PID back-up" in text for _, text in run["statustexts"]), run["statustexts"]
    metrics = result.metrics
    assert metrics["solves_failed"] == 0
    assert metrics["alt_loss_max_m"] < 3.0  # it fell 100 m before
    assert metrics["roll_max_abs_deg"] < 15.0 and metrics["pitch_max_abs_deg"] < 25.0
    assert metrics["vx_rmse_after_failure"] < 1.0  # the PID, in the same flight: ~1.4 m/s


def test_with_the_servo_moment_bound_the_mpc_holds_a_rotor_jammed_past_horizontal(tmp_path: Path) -> None:
    scenario = build_scenario("servo-failure", {"servo": 1, "jam_deg": 95.0, "jam_speed_mps": 9.0, "duration_s": 10.0})
    result = run_scenario(scenario, "mpc", tmp_path, record=False, autopilot_params={"VT_MPC_Q_MOM_SRV": 10000.0})
    run = json.loads((result.run_dir / "run.json").read_text())
    assert any("jam detected" in text for _, text in run["statustexts"]), run["statustexts"]
    assert not any("PID back-up" in text for _, text in run["statustexts"]), run["statustexts"]
    assert result.metrics["survived"]  # the default: 3 failed solves, the PID's back-up, past 60 deg of roll
