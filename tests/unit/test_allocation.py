"""Control allocation (docs/autopilot.md): hand-checkable hover cases, saturation, failures, cruise
redistribution, NaN safety.

Hand derivation used below (docs/model.md, body FRD, zero tilt): rotor i pushes F_i = T_i (0, 0, -1), so its
moment is r_i x F_i = (-y_i T_i, x_i T_i, 0) plus the reaction torque d_i (c_K/c_F) T_i (0, 0, -1):
  roll  L = -sum y_i T_i         -> positive roll (right wing down) needs the LEFT rotors 3, 4 (y = -0.5);
  pitch M = +sum x_i T_i         -> positive pitch (nose up) needs the FRONT rotors 1, 4 (x = +0.866);
  yaw   N = -0.05 sum d_i T_i    -> with d = (+1, -1, +1, -1), positive yaw (nose right) needs rotors 2 and 4.
Each pattern below changes only its own axis (the other three sums cancel), so with T_max = 26.37 N:
  roll  u = hover + dL (-1, -1, +1, +1), L = 4 * 0.5   * T_max * dL
  pitch u = hover + dM (+1, -1, -1, +1), M = 4 * 0.866 * T_max * dM
  yaw   u = hover + dN (-1, +1, -1, +1), N = 4 * 0.05  * T_max * dN
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from aircraft.actuators import ALLOCATED_ROTORS, ALLOCATED_SURFACES
from aircraft.airframe import Airframe, load_airframe
from aircraft.wrench import actuator_wrench
from autopilot.control.allocation import (
    LOWER_NOMINAL,
    STATUS_INVALID_INPUT,
    UPPER_NOMINAL,
    AllocationResult,
    ControlAllocator,
)
from autopilot.control.allocation_qp import build_allocation_functions

ZERO3 = np.zeros(3)
ZERO4 = np.zeros(4)
CRUISE_TILTS = np.full(4, math.pi / 2)
CRUISE_AIR = np.array([26.0, 0.0, 0.0])


@pytest.fixture(scope="module")
def airframe() -> Airframe:
    return load_airframe()


@pytest.fixture(scope="module")
def model(airframe: Airframe) -> ca.Function:
    """The shared model evaluated independently of the allocator: W(u; tilts, v_air_body, rates_body)."""
    u, tilts, v, w = ca.SX.sym("u", 8), ca.SX.sym("tilts", 4), ca.SX.sym("v", 3), ca.SX.sym("w", 3)
    return ca.Function("wrench", [u, tilts, v, w], [actuator_wrench(airframe, u, tilts, v, w)])


def wrench_of(model: ca.Function, u, tilts=ZERO4, v_air=ZERO3, rates=ZERO3) -> np.ndarray:
    return np.asarray(model(np.asarray(u, float), tilts, v_air, rates)).ravel()


def hover_fraction(airframe: Airframe) -> float:
    return airframe.mass * airframe.gravity / 4 / airframe.thrust_max


def hover_allocator(airframe: Airframe) -> ControlAllocator:
    """An allocator whose previous solution is the hover trim."""
    return ControlAllocator(airframe, u_initial=[hover_fraction(airframe)] * 4 + [0.0] * 4)


def weight(airframe: Airframe) -> float:
    return airframe.mass * airframe.gravity


def assert_clean(result: AllocationResult, allocator: ControlAllocator) -> None:
    """No NaN anywhere, and u within the allocator's current bounds."""
    for array in (result.u, result.achieved, result.residual):
        assert np.all(np.isfinite(array))
    assert np.all(result.u >= allocator.lower) and np.all(result.u <= allocator.upper)


def test_geometry_used_by_the_hand_derivations(airframe: Airframe) -> None:
    assert airframe.rotor_positions == ((0.866, 0.5, 0.0), (-0.866, 0.5, 0.0), (-0.866, -0.5, 0.0), (0.866, -0.5, 0.0))
    assert airframe.spin_directions == (1.0, -1.0, 1.0, -1.0)
    assert airframe.torque_coefficient / airframe.thrust_coefficient == pytest.approx(0.05, rel=1e-3)
    assert hover_fraction(airframe) == pytest.approx(0.6906, abs=1e-4)


def test_hover_from_rest(airframe: Airframe, model: ca.Function) -> None:
    allocator = ControlAllocator(airframe)  # previous solution: everything at 0
    result = allocator.allocate(np.array([0.0, 0.0, -weight(airframe), 0.0, 0.0, 0.0]), ZERO4, ZERO3, ZERO3)
    assert result.status == "solved" and result.ok and not result.fallback
    np.testing.assert_allclose(result.u[ALLOCATED_ROTORS], 0.6906, atol=1e-3)
    np.testing.assert_allclose(result.u[ALLOCATED_ROTORS], hover_fraction(airframe), atol=1e-6)
    # No effect at zero airspeed: least effort keeps 0.
    np.testing.assert_allclose(result.u[ALLOCATED_SURFACES], 0.0, atol=1e-9)
    np.testing.assert_allclose(result.achieved, wrench_of(model, result.u), atol=1e-9)
    np.testing.assert_allclose(result.residual, [0, 0, -weight(airframe), 0, 0, 0] - result.achieved, atol=1e-12)
    assert np.linalg.norm(result.residual) < 1e-4


@pytest.mark.parametrize(
    ("axis", "torque", "pattern", "lever"),
    [
        (3, 2.0, (-1, -1, 1, 1), 0.5),  # roll right: left rotors 3, 4 up
        (4, 3.0, (1, -1, -1, 1), 0.866),  # pitch up: front rotors 1, 4 up
        (5, 1.0, (-1, 1, -1, 1), 0.05),  # yaw right: rotors 2, 4 (spin -1) up
        (3, -2.0, (-1, -1, 1, 1), 0.5),  # and the opposite signs
        (4, -3.0, (1, -1, -1, 1), 0.866),
        (5, -1.0, (-1, 1, -1, 1), 0.05),
    ],
)
def test_pure_torque_around_hover(
    airframe: Airframe, model: ca.Function, axis: int, torque: float, pattern: tuple[int, ...], lever: float
) -> None:
    allocator = hover_allocator(airframe)
    demand = np.array([0.0, 0.0, -weight(airframe), 0.0, 0.0, 0.0])
    demand[axis] = torque
    result = allocator.allocate(demand, ZERO4, ZERO3, ZERO3)
    assert result.ok
    assert np.linalg.norm(result.residual) < 1e-3 * abs(torque)
    np.testing.assert_allclose(result.achieved, wrench_of(model, result.u), atol=1e-9)
    delta = torque / (4 * lever * airframe.thrust_max)  # hand derivation in the module docstring
    expected = hover_fraction(airframe) + delta * np.array(pattern)
    np.testing.assert_allclose(result.u[ALLOCATED_ROTORS], expected, atol=1e-3 * abs(delta))
    signs = np.sign(result.u[ALLOCATED_ROTORS] - hover_fraction(airframe))
    np.testing.assert_array_equal(signs, np.sign(torque) * np.array(pattern))
    np.testing.assert_allclose(result.u[ALLOCATED_SURFACES], 0.0, atol=1e-9)


def test_extra_upward_force_raises_all_rotors_equally(airframe: Airframe) -> None:
    allocator = hover_allocator(airframe)
    extra = 10.0  # N upward, i.e. -z
    result = allocator.allocate(np.array([0.0, 0.0, -weight(airframe) - extra, 0, 0, 0]), ZERO4, ZERO3, ZERO3)
    expected = (weight(airframe) + extra) / 4 / airframe.thrust_max
    np.testing.assert_allclose(result.u[ALLOCATED_ROTORS], expected, atol=1e-6)
    assert np.ptp(result.u[ALLOCATED_ROTORS]) < 1e-9
    assert np.linalg.norm(result.residual) < 1e-3


def test_saturation_reports_the_residual(airframe: Airframe, model: ca.Function) -> None:
    allocator = hover_allocator(airframe)
    demand = np.array([0.0, 0.0, -200.0, 0.0, 0.0, 0.0])  # capacity is 4 x 26.37 = 105.5 N
    result = allocator.allocate(demand, ZERO4, ZERO3, ZERO3)
    assert result.ok
    np.testing.assert_array_equal(result.u[ALLOCATED_ROTORS], 1.0)  # at the upper bound, exactly (clipped)
    np.testing.assert_allclose(result.achieved, wrench_of(model, result.u), atol=1e-9)
    np.testing.assert_allclose(result.residual, demand - result.achieved, atol=1e-12)
    assert result.residual[2] == pytest.approx(-200.0 + 4 * airframe.thrust_max, abs=1e-6)
    assert_clean(result, allocator)


def test_saturated_roll_uses_the_full_range(airframe: Airframe) -> None:
    allocator = hover_allocator(airframe)
    demand = np.array([0.0, 0.0, -weight(airframe), 100.0, 0.0, 0.0])  # far beyond the rotors' roll authority
    result = allocator.allocate(demand, ZERO4, ZERO3, ZERO3)
    assert_clean(result, allocator)
    # At the bounds, to the solver's tolerance.
    np.testing.assert_allclose(result.u[ALLOCATED_ROTORS], [0.0, 0.0, 1.0, 1.0], atol=1e-6)
    assert result.residual[3] > 0 and np.linalg.norm(result.residual) > 1.0


def test_dead_rotor_stays_at_zero(airframe: Airframe) -> None:
    allocator = hover_allocator(airframe)
    allocator.set_failed(1)
    for torque in (0.0, 2.0, -2.0):
        result = allocator.allocate(np.array([0, 0, -weight(airframe), 0, torque, 0.0]), ZERO4, ZERO3, ZERO3)
        assert_clean(result, allocator)
        assert result.u[1] == 0.0
    np.testing.assert_array_equal(allocator.effectiveness_matrix[:, 1], 0.0)
    assert np.linalg.norm(result.residual) > 1e-2  # three rotors cannot hold four axes: reported, best effort
    allocator.clear(1)
    result = allocator.allocate(np.array([0, 0, -weight(airframe), 0, 0, 0.0]), ZERO4, ZERO3, ZERO3)
    assert result.u[1] > 0.5 and np.linalg.norm(result.residual) < 1e-3


def test_partial_rotor_cap_is_respected(airframe: Airframe) -> None:
    allocator = hover_allocator(airframe)
    allocator.set_actuator_limit(1, 0.0, 0.7)  # rotor 2 at most 70 %
    demand = np.array([0.0, 0.0, -weight(airframe), 0.0, 0.0, 1.0])  # healthy: rotor 2 would go to 0.88
    result = allocator.allocate(demand, ZERO4, ZERO3, ZERO3)
    assert_clean(result, allocator)
    assert result.u[1] == pytest.approx(0.7, abs=1e-12)
    np.testing.assert_allclose(allocator.upper[ALLOCATED_ROTORS], [1.0, 0.7, 1.0, 1.0])
    # The four rotors are the only effective actuators in hover (a square system), so with rotor 2 capped the yaw
    # cannot be met; the least-squares compromise keeps the strong axes and gives up most of the weak yaw.
    assert 0.0 < result.achieved[5] < 0.2 and result.residual[5] > 0.8
    assert np.linalg.norm(result.residual[[2, 3, 4]]) < 0.2


def test_reduced_rudder_bounds_in_cruise(airframe: Airframe) -> None:
    demand = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 100.0])  # more yaw than rotors and rudder together can give
    healthy = ControlAllocator(airframe).allocate(demand, CRUISE_TILTS, CRUISE_AIR, ZERO3)
    assert healthy.u[7] == pytest.approx(1.0, abs=1e-9)
    allocator = ControlAllocator(airframe)
    allocator.set_actuator_limit(7, -0.2, 0.2)  # the paper's "rudder 20 % effective" as bounds
    result = allocator.allocate(demand, CRUISE_TILTS, CRUISE_AIR, ZERO3)
    assert_clean(result, allocator)
    assert result.u[7] == pytest.approx(0.2, abs=1e-12)
    assert result.residual[5] > healthy.residual[5]


def test_reduced_effectiveness_scales_the_column(airframe: Airframe, model: ca.Function) -> None:
    allocator = ControlAllocator(airframe)
    demand = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 100.0])
    healthy = allocator.allocate(demand, CRUISE_TILTS, CRUISE_AIR, ZERO3)
    column = allocator.effectiveness_matrix[:, 7]
    allocator.set_effectiveness(7, 0.2)  # the plant's WRONG failure: moment x 0.2, command keeps +-1
    result = allocator.allocate(demand, CRUISE_TILTS, CRUISE_AIR, ZERO3)
    np.testing.assert_allclose(allocator.effectiveness_matrix[:, 7], 0.2 * column, rtol=1e-12)
    assert result.u[7] == pytest.approx(1.0, abs=1e-9)
    scaled = result.u.copy()
    scaled[7] *= 0.2
    np.testing.assert_allclose(result.achieved, wrench_of(model, scaled, CRUISE_TILTS, CRUISE_AIR), atol=1e-9)
    assert result.residual[5] > healthy.residual[5]


def test_failure_api_refuses_bad_arguments(airframe: Airframe) -> None:
    allocator = ControlAllocator(airframe)
    for bad in ((8, 0.0, 1.0), (-1, 0.0, 1.0), (0, -0.1, 1.0), (0, 0.0, 1.1), (4, 0.5, 0.4), (0, math.nan, 1.0)):
        with pytest.raises(ValueError):
            allocator.set_actuator_limit(*bad)
    for bad_fraction in (-0.1, 1.5, math.nan):
        with pytest.raises(ValueError):
            allocator.set_effectiveness(7, bad_fraction)
    with pytest.raises(TypeError):
        allocator.set_failed(1.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError):
        ControlAllocator(airframe, wrench_weights=[1.0] * 5)
    np.testing.assert_array_equal(allocator.lower, [0, 0, 0, 0, -1, -1, -1, -1])  # nothing changed
    np.testing.assert_array_equal(allocator.upper, 1.0)


def test_cruise_rotor1_failure_is_redistributed(airframe: Airframe, model: ca.Function) -> None:
    """Tilts 90 deg at 26 m/s: the healthy allocation's achieved wrench is a feasible demand; with rotor 1 dead the
    allocator meets it with rotor 2 (the other right-hand rotor) taking over and the ailerons trimming its roll."""
    allocator = ControlAllocator(airframe)
    trim = np.array([6.44, 0.0, -weight(airframe), 0.0, 0.0, 0.0])  # drag ~6.4 N; the wing lifts only 63.7 N
    healthy = allocator.allocate(trim, CRUISE_TILTS, CRUISE_AIR, ZERO3)
    assert healthy.ok and np.ptp(healthy.u[ALLOCATED_ROTORS]) < 1e-6
    feasible = healthy.achieved
    allocator.set_failed(0)
    for _ in range(3):  # the closed loop calls it every 4 ms; the least-change bias decays geometrically
        result = allocator.allocate(feasible, CRUISE_TILTS, CRUISE_AIR, ZERO3)
        assert_clean(result, allocator)
        assert result.u[0] == 0.0
    assert np.linalg.norm(result.residual) < 1e-6 * np.linalg.norm(feasible)
    np.testing.assert_allclose(result.achieved, wrench_of(model, result.u, CRUISE_TILTS, CRUISE_AIR), atol=1e-9)
    assert result.u[1] == pytest.approx(2 * healthy.u[1], rel=1e-3)  # yaw balance: T2 = T3 + T4, Fx = 2 T2
    assert result.u[1] == max(result.u[ALLOCATED_ROTORS])
    assert abs(result.u[4] - result.u[5]) > 1e-2  # differential aileron cancels rotor 2's reaction roll


def test_non_finite_demand_returns_the_previous_u(airframe: Airframe) -> None:
    allocator = hover_allocator(airframe)
    good = allocator.allocate(np.array([0, 0, -weight(airframe), 1.0, 0, 0]), ZERO4, ZERO3, ZERO3)
    for demand, tilts, air in (
        (np.array([0, 0, math.nan, 0, 0, 0]), ZERO4, ZERO3),
        (np.array([0, math.inf, 0, 0, 0, 0]), ZERO4, ZERO3),
        (np.array([0, 0, -weight(airframe), 0, 0, 0]), np.array([0, math.nan, 0, 0]), ZERO3),
        (np.array([0, 0, -weight(airframe), 0, 0, 0]), ZERO4, np.array([-math.inf, 0, 0])),
    ):
        result = allocator.allocate(demand, tilts, air, ZERO3)
        assert result.fallback and not result.ok and result.status == STATUS_INVALID_INPUT
        np.testing.assert_array_equal(result.u, good.u)
        assert_clean(result, allocator)
    result = allocator.allocate(np.array([0, 0, -weight(airframe), 0, 0, 0]), ZERO4, ZERO3, ZERO3)
    assert result.ok and np.linalg.norm(result.residual) < 1e-3  # and it carries on


def test_fallback_respects_a_new_failure(airframe: Airframe) -> None:
    allocator = hover_allocator(airframe)
    allocator.set_failed(2)
    result = allocator.allocate(np.full(6, math.nan), ZERO4, ZERO3, ZERO3)
    assert result.fallback and result.u[2] == 0.0
    assert_clean(result, allocator)


def test_solver_failure_falls_back(airframe: Airframe) -> None:
    allocator = ControlAllocator(airframe, max_iter=1)  # too few iterations for a saturated demand from rest
    result = allocator.allocate(np.array([0.0, 0.0, -200.0, 0.0, 0.0, 0.0]), ZERO4, ZERO3, ZERO3)
    assert result.fallback and result.status == "max_iter_reached"
    np.testing.assert_array_equal(result.u, 0.0)
    assert_clean(result, allocator)


def test_effectiveness_matrix_matches_finite_differences(airframe: Airframe, model: ca.Function) -> None:
    tilts = np.radians([10.0, 35.0, 60.0, 80.0])
    v_air = np.array([15.0, 1.0, 2.0])
    rates = np.array([0.2, -0.1, 0.3])
    u0 = np.array([0.4, 0.5, 0.3, 0.6, 0.1, -0.2, 0.3, -0.4])
    allocator = ControlAllocator(airframe, u_initial=u0)
    allocator.allocate(wrench_of(model, u0, tilts, v_air, rates), tilts, v_air, rates)
    step = 1e-6
    numeric = np.empty((6, 8))
    for j in range(8):
        e = np.zeros(8)
        e[j] = step
        numeric[:, j] = wrench_of(model, u0 + e, tilts, v_air, rates) - wrench_of(model, u0 - e, tilts, v_air, rates)
        numeric[:, j] /= 2 * step
    np.testing.assert_allclose(allocator.effectiveness_matrix, numeric, atol=1e-6)
    assert np.abs(numeric[3:6, ALLOCATED_SURFACES]).max() > 1.0  # the surfaces act at 15 m/s: the check covers them too


def test_vm_and_compiled_agree(airframe: Airframe) -> None:
    demand = np.array([3.0, 0.5, -60.0, 0.5, -0.4, 0.3])
    tilts, v_air, rates = np.radians([30.0, 31.0, 29.0, 30.0]), np.array([12.0, 0.5, 1.0]), np.array([0.1, 0, -0.1])
    compiled = ControlAllocator(airframe).allocate(demand, tilts, v_air, rates)
    vm = ControlAllocator(airframe, compile_model=False).allocate(demand, tilts, v_air, rates)
    np.testing.assert_allclose(compiled.u, vm.u, atol=1e-9)
    np.testing.assert_allclose(compiled.achieved, vm.achieved, atol=1e-9)


def test_row_weights_set_priorities(airframe: Airframe) -> None:
    """Infeasible demand (thrust beyond capacity plus roll): weighting the moment rows keeps the roll."""
    demand = np.array([0.0, 0.0, -150.0, 10.0, 0.0, 0.0])
    plain = hover_allocator(airframe).allocate(demand, ZERO4, ZERO3, ZERO3)
    attitude_first = ControlAllocator(
        airframe, wrench_weights=[1, 1, 1, 1e3, 1e3, 1e3], u_initial=[hover_fraction(airframe)] * 4 + [0.0] * 4
    ).allocate(demand, ZERO4, ZERO3, ZERO3)
    assert plain.residual[3] == pytest.approx(10.0, abs=1e-6)  # identity weights: all rotors to 1, roll lost
    assert abs(attitude_first.residual[3]) < 0.02 * abs(plain.residual[3])


def test_random_inputs_never_give_nan(airframe: Airframe) -> None:
    rng = np.random.default_rng(7)
    allocator = ControlAllocator(airframe)
    allocator.set_actuator_limit(3, 0.0, 0.5)
    allocator.set_failed(6)
    for k in range(300):
        demand = rng.normal(0.0, 50.0, 6)
        if k % 17 == 0:
            demand[rng.integers(6)] = rng.choice([math.nan, math.inf, -math.inf])
        tilts = rng.uniform(math.radians(-7), math.radians(95), 4)
        result = allocator.allocate(demand, tilts, rng.normal(0.0, 15.0, 3), rng.normal(0.0, 1.0, 3))
        assert_clean(result, allocator)
        assert result.u[6] == 0.0 and result.u[3] <= 0.5


def flight_like_demands(airframe: Airframe) -> list[tuple[np.ndarray, np.ndarray]]:
    """(wrench set-point, body airspeed) along a PID takeoff: a climb beyond the rotors' capacity with the
    inflow growing, then hover with pitch steps that saturate the rotors, as an Offboard velocity step makes."""
    weight_n = weight(airframe)
    sequence = []
    for k in range(60):
        sequence.append((np.array([-3e-4 * k, 0.0, -1.6 * weight_n + 0.4 * k, 0.0, 4e-4 * k, 0.0]),
                         np.array([3e-5 * k, 0.0, -0.018 * k])))  # fmt: skip
    rng = np.random.default_rng(3)
    for k in range(400):
        moment = np.array([0.0, -40.0 if k % 100 < 5 else 0.0, 0.0]) + rng.normal(0.0, 0.2, 3)
        force = np.array([0.0, 0.0, -weight_n]) + rng.normal(0.0, 1.0, 3)
        sequence.append((np.concatenate((force, moment)), np.array([0.02 * (k % 100), 0.0, 0.01])))
    return sequence


def test_warm_started_answers_equal_a_cold_solve_along_a_flight(airframe: Airframe) -> None:
    """The persistent, warm-started solver answers each call as a fresh solver would. proxsuite 0.8.0 updated
    without its preconditioner drifted within tens of calls here and answered "solved" 0.45 from the optimum (a
    PID flight fell from 20 m in Offboard)."""
    weights = [0.0, 0.0, 1.0, 100.0, 100.0, 1.0]  # the PID's hover weights
    allocator = ControlAllocator(airframe, wrench_weights=weights, u_initial=[hover_fraction(airframe)] * 4 + [0.0] * 4)
    cold = ControlAllocator(airframe, wrench_weights=weights)
    worst = 0.0
    for demand, v_air in flight_like_demands(airframe):
        cold.reset(allocator.u)  # the same u_trim, a fresh solver
        expected = cold.allocate(demand, ZERO4, v_air, ZERO3)
        result = allocator.allocate(demand, ZERO4, v_air, ZERO3)
        assert result.ok and expected.ok
        worst = max(worst, float(np.max(np.abs(result.u - expected.u))))
    assert worst < 2e-3
    assert allocator.restarts == 0  # the preconditioner update alone keeps it right


def test_optimality_gap_is_zero_at_the_solution_and_the_distance_elsewhere(airframe: Airframe) -> None:
    """The check behind the allocator's restarts: the projected gradient step at u, in actuator units."""
    _, wrench_function = build_allocation_functions(airframe)
    weights = np.array([1.0, 1.0, 1.0, 100.0, 100.0, 1.0])
    allocator = ControlAllocator(airframe, wrench_weights=weights, u_initial=[hover_fraction(airframe)] * 4 + [0.0] * 4)
    demand = np.array([0.0, 0.0, -weight(airframe), 0.5, -1.0, 0.2])
    solution = allocator.allocate(demand, ZERO4, ZERO3, ZERO3).u
    args = (ZERO4, ZERO3, ZERO3, demand, weights, 1e-6, LOWER_NOMINAL, UPPER_NOMINAL)
    ones = np.ones(8)
    _, gap = wrench_function(solution, ones, *args)
    assert float(gap) < 1e-6
    off = solution.copy()
    off[1] -= 0.2  # rotor 2, far from its bounds, 0.2 from the optimum
    _, gap = wrench_function(off, ones, *args)
    assert 0.05 < float(gap) < 0.5
    saturated = np.array([1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0])  # all at the upper bound, pushing up: optimal
    _, gap = wrench_function(saturated, ones, ZERO4, ZERO3, ZERO3, np.array([0.0, 0.0, -200.0, 0.0, 0.0, 0.0]),
                             np.ones(6), 1e-6, LOWER_NOMINAL, UPPER_NOMINAL)  # fmt: skip
    assert float(gap) < 1e-6
