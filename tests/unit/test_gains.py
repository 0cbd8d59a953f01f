"""The gains as parameters (docs/mavlink.md section 9, "Gains"): the attitude loop's (MC_*), the PID baseline's
(MPC_*, FW_*, VT_*) and the MPC's weights and limits (VT_MPC_*), their defaults the built-in ones, applied to a
running flight controller when they change, and a campaign axis."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aircraft.airframe import load_airframe
from autopilot.control.attitude import DEFAULT_GAINS, AttitudeController
from autopilot.control.pid_baseline import PidParameters
from autopilot.control.tuning import attitude_gains, pid_parameters
from autopilot.controllers import MPC, PID, build_flight_controller
from autopilot.mpc.horizon import LONG
from autopilot.mpc.model import P_ATTITUDE_BOUND, P_GAINS, P_WEIGHTS, MpcLimits, MpcWeights
from autopilot.mpc.rti import RtiSolver
from autopilot.mpc.tuning import mpc_limits, mpc_weights
from autopilot.storage.parameters import ParameterRejected, ParameterStore
from ground_tools.campaign.points import campaign_points
from ground_tools.campaign.spec import CampaignError, load_campaign


@pytest.fixture(scope="module")
def airframe():
    return load_airframe()


def test_the_parameters_defaults_are_the_built_in_gains_weights_and_limits():
    params = ParameterStore(None)
    assert attitude_gains(params) == DEFAULT_GAINS
    assert pid_parameters(params) == PidParameters()
    assert mpc_weights(params) == MpcWeights()
    assert mpc_weights(params, LONG.weights) == LONG.weights
    assert mpc_limits(params) == MpcLimits()


def test_a_px4_rate_gain_is_refused_with_the_range_that_says_the_unit():
    """PX4's MC_ROLLRATE_P is a normalised torque per rad/s (0.15); here it is an angular acceleration per rad/s."""
    params = ParameterStore(None)
    with pytest.raises(ParameterRejected, match=r"MC_ROLLRATE_P: 0.15 outside 2..80"):
        params.set("MC_ROLLRATE_P", 0.15)


def test_the_rate_gain_scales_the_attitude_loops_demand(airframe):
    """The loop's torque for a roll-rate error alone (attitude on its set-point): K_p times the error, I_xx N m."""
    params = ParameterStore(None)
    loop = AttitudeController(airframe, attitude_gains(params))
    rates = np.array([0.2, 0.0, 0.0])

    def roll_torque() -> float:  # the same rates at every tick: no damping term
        return float(loop.update(np.zeros(3), rates, np.zeros(3))[0])

    before = roll_torque()
    params.set("MC_ROLLRATE_P", 40.0)
    loop.set_gains(attitude_gains(params))
    after = roll_torque()
    assert before == pytest.approx(-20.0 * 0.2 * airframe.inertia_diag[0], rel=1e-9)
    assert after == pytest.approx(2 * before, rel=1e-9)


@pytest.mark.parametrize("kind", [MPC, PID])
def test_a_running_flight_controller_is_retuned(airframe, kind):
    params = ParameterStore(None)
    controller = build_flight_controller(airframe, kind, params)
    params.set("MC_YAW_P", 4.0)
    params.set("MPC_XY_VEL_P_ACC", 3.0)
    params.set("VT_MPC_Q_VN", 80.0)
    params.set("VT_MPC_ATT_MAX", 30.0)
    controller.retune(params)
    assert controller.attitude.gains.attitude[2] == 4.0
    assert controller.pid.p.mc_vel_p_xy == 3.0 and controller.pid.p.yaw_attitude_gain == 4.0
    if kind == MPC:
        rows = controller.mpc.solver.stage_parameters(np.zeros_like(controller.mpc.params))
        assert np.all(rows[P_GAINS][2] == 4.0)  # the MPC's model of the attitude loop
        assert np.all(rows[P_WEIGHTS][0] == 80.0)
        assert np.allclose(rows[P_ATTITUDE_BOUND], math.radians(30.0))
        assert controller.mpc.limits.attitude == (math.radians(30.0),) * 2


def test_a_changed_weight_changes_the_plan_and_the_built_in_terms_stay(airframe):
    """A heavier north-velocity weight makes the first plan chase a north set-point harder; a weight that shapes the
    problem (the soft bound's) cannot change once it is built."""

    def first_pitch_sp(q_vn: float) -> float:
        solver = RtiSolver(airframe)
        solver.set_tuning(DEFAULT_GAINS, MpcWeights(q_ref=(q_vn, 10.0, 50.0)), MpcLimits())
        x0 = np.zeros(16)
        solver.initialise(x0, airframe.hover_thrust_per_rotor)
        params = np.zeros((solver.params.shape[0], solver.horizon + 1))
        params[0] = 5.0  # 5 m/s north
        params[4:8] = 1.0  # every servo works
        for _ in range(10):
            solution = solver.solve(x0, params)
        assert solution.ok
        return float(solver.inputs()[0][9])

    assert first_pitch_sp(80.0) < first_pitch_sp(20.0) < 0.0  # nose down, further with the heavier weight
    solver = RtiSolver(airframe)
    with pytest.raises(ValueError, match="Table 2"):
        solver.set_tuning(DEFAULT_GAINS, MpcWeights(q_attitude_bound=0.0), MpcLimits())


def test_an_autopilot_parameter_is_a_campaign_axis(tmp_path):
    path = tmp_path / "weights.toml"
    path.write_text('scenario = "accel"\ncontrollers = ["mpc"]\n[fixed]\nduration_s = 2\nMC_ROLL_P = 5.0\n'
                    "[axes]\nVT_MPC_Q_VN = [5, 80]\n")  # fmt: skip
    points = campaign_points(load_campaign(path))
    assert sorted(p.params["VT_MPC_Q_VN"] for p in points) == [5.0, 80.0]
    assert all(p.params["MC_ROLL_P"] == 5.0 for p in points)
    path.write_text('scenario = "accel"\n[axes]\nVT_MPC_Q_VN = [5, 1e9]\n')
    with pytest.raises(CampaignError, match="VT_MPC_Q_VN: 1e\\+09 outside 0..10000"):
        load_campaign(path)
