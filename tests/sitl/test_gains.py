"""The gains as parameters through MAVLink (docs/mavlink.md section 9, "Gains"): MC_ROLLRATE_P set in flight changes
the roll step response as the attitude loop's law says, and a campaign sweeps an MPC weight."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import duckdb
import numpy as np
import pytest

from aircraft.airframe import load_airframe
from aircraft.frames import quaternion_from_euler
from autopilot.control.flight_controller import ATTITUDE_PERIOD_USEC
from tests.sitl.ground_station import OFFBOARD
from tests.sitl.test_mavlink_failsafes import hovering, set_param
from tests.unit.test_mavlink_offboard_attitude import ATTITUDE_MASK
from transport.mavlink import mavlink as M

AIRFRAME = load_airframe()
HOVER = AIRFRAME.hover_thrust_per_rotor / AIRFRAME.thrust_max
STEP = math.radians(8.0)
ATTITUDE_P, RATE_D = 6.0, 2.0  # MC_ROLL_P, MC_ROLLRATE_D at their defaults
ROTOR_LAG_S = 0.02  # the rotors' thrust lag (12.5 ms up, 25 ms down in the airframe file), as one first-order lag
PLANT_STEP_S = 0.0025


def law_step_response(rate_p: float, seconds: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """The roll (rad) after a roll set-point step of STEP, by the attitude loop's law alone (autopilot/control/
    attitude.py: P on the angle with its smooth rate limit, P and D on the rate, at 250 Hz) on a rigid roll axis
    whose angular acceleration follows the demand with the rotors' lag."""
    times, rolls = [], []
    roll = rate = acceleration = demand = previous_rate = 0.0
    next_tick = 0.0
    for k in range(int(round(seconds / PLANT_STEP_S))):
        t = k * PLANT_STEP_S
        if t >= next_tick - 1e-12:
            rate_sp = math.pi * math.tanh(ATTITUDE_P * (STEP - roll) / math.pi)
            demand = rate_p * (rate_sp - rate) + RATE_D * (previous_rate - rate)
            previous_rate = rate
            next_tick += ATTITUDE_PERIOD_USEC / 1e6
        acceleration += (demand - acceleration) * PLANT_STEP_S / ROTOR_LAG_S
        rate += acceleration * PLANT_STEP_S
        roll += rate * PLANT_STEP_S
        times.append(t + PLANT_STEP_S)
        rolls.append(roll)
    return np.array(times), np.array(rolls)


def rise_and_overshoot(times: np.ndarray, rolls: np.ndarray) -> tuple[float, float]:
    """The 10-90 % rise time (s) and the overshoot (% of the step)."""
    rise = times[np.argmax(rolls > 0.9 * STEP)] - times[np.argmax(rolls > 0.1 * STEP)]
    return float(rise), float((rolls.max() / STEP - 1) * 100)


def test_a_changed_roll_rate_gain_changes_the_roll_step_as_the_law_says(tmp_path):
    """Hovering in Offboard attitude, an 8 deg roll step with MC_ROLLRATE_P 8, 20 (the default) and 40, each set
    in flight by PARAM_SET: the measured 10-90 % rise time and overshoot are the loop law's."""
    measured = {}
    with hovering(tmp_path) as gs:
        mav = gs.conn.mav
        assert gs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE, 2500).result == 0
        set_param(gs, "COM_OF_LOSS_T", 5.0)  # lockstep runs faster than the wall clock the set-points are sent on
        target = {"q": quaternion_from_euler(0.0, 0.0, 0.0)}

        def send() -> None:
            mav.set_attitude_target_send(gs.time_boot_ms, gs.vehicle, 1, ATTITUDE_MASK, target["q"], 0, 0, 0, HOVER)

        send()
        gs.pump(0.1)
        assert gs.set_mode(OFFBOARD).result == M.MAV_RESULT_ACCEPTED
        for gain in (8.0, 20.0, 40.0):
            set_param(gs, "MC_ROLLRATE_P", gain)
            target["q"] = quaternion_from_euler(0.0, 0.0, 0.0)
            gs.wait_sim(1.5, every=send)
            with gs.recording("ATTITUDE") as samples:
                target["q"] = quaternion_from_euler(STEP, 0.0, 0.0)
                send()
                gs.wait_sim(1.0, every=send)
            times = np.array([m.time_boot_ms / 1000.0 for m in samples])
            measured[gain] = rise_and_overshoot(times, np.array([m.roll for m in samples]))
    for gain, (rise, overshoot) in measured.items():
        law_rise, law_overshoot = rise_and_overshoot(*law_step_response(gain))
        print(f"MC_ROLLRATE_P {gain:g}: rise {rise:.3f} s (law {law_rise:.3f}), overshoot {overshoot:.1f} % "
              f"(law {law_overshoot:.1f})")  # fmt: skip
        assert rise == pytest.approx(law_rise, rel=0.15)
        assert overshoot == pytest.approx(law_overshoot, abs=3.0)
    assert measured[8.0][1] > 8.0 > measured[20.0][1]  # the low gain overshoots, the default does not
    assert measured[40.0][0] > measured[20.0][0]  # a stiffer rate loop rolls slower: the angle's P leads


WEIGHTS = """scenario = "accel"
controllers = ["mpc"]
[fixed]
duration_s = 4.0
[axes]
VT_MPC_Q_VN = [2, 200]
"""


def test_a_campaign_sweeps_an_mpc_weight(tmp_path: Path) -> None:
    """Two accel flights (the first 4 s of the ramp to 27.74 m/s north) with the north-velocity weight 2 and 200:
    each flight's autopilot ran with its weight, and the heavier one tracks the ramp closer."""
    (tmp_path / "weights.toml").write_text(WEIGHTS)
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "ground_tools", "campaign", str(tmp_path / "weights.toml"), "--out",
                           str(out), "--workers", "1", "--no-progress"], capture_output=True, text=True,
                          timeout=500)  # fmt: skip
    assert done.returncode == 0, done.stderr
    with duckdb.connect(str(out / "campaign.duckdb"), read_only=True) as db:
        rows = db.execute("SELECT VT_MPC_Q_VN, vx_rmse, run_dir FROM flights WHERE status = 'done'").fetchall()
    assert len(rows) == 2
    errors = {}
    for weight, vx_rmse, run_dir in rows:
        stored = json.loads((Path(run_dir) / "params.json").read_text())["parameters"]
        assert stored == {"VT_MPC_Q_VN": weight}
        errors[weight] = vx_rmse
    print(f"north velocity RMSE: weight 2 {errors[2.0]:.3f} m/s, weight 200 {errors[200.0]:.3f} m/s")
    assert errors[200.0] < errors[2.0]
