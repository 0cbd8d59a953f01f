"""The plant's physics in-process: compiled step = CasADi VM, drop, hover, ground, actuators and failures."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim_bridge.dynamics import POSITION, ROTOR_SPEED, SURFACE, TILT, VELOCITY
from sim_bridge.failures import FailureRejected
from sim_bridge.plant import DT, Plant, Spawn, hover_command

STEPS_PER_SECOND = int(round(1 / DT))


def run(plant: Plant, seconds: float, command: np.ndarray | None = None) -> None:
    if command is not None:
        plant.set_command(command)
    for _ in range(int(round(seconds * STEPS_PER_SECOND))):
        plant.step()


def test_compiled_step_is_bit_identical_to_the_casadi_vm(airframe):
    compiled = Plant(airframe, Spawn(altitude=50.0))
    interpreted = Plant(airframe, Spawn(altitude=50.0), compile_model=False)
    rng = np.random.default_rng(1)
    for _ in range(200):
        command = hover_command(airframe) + np.concatenate((rng.uniform(-0.05, 0.05, 4), rng.uniform(0, 1, 4),
                                                            rng.uniform(-1, 1, 4)))  # fmt: skip
        for plant in (compiled, interpreted):
            plant.set_command(command)
            plant.step()
    assert np.array_equal(compiled.state, interpreted.state)
    assert np.array_equal(compiled.specific_force, interpreted.specific_force)


def test_with_rotors_stopped_it_falls_at_g(airframe):
    plant = Plant(airframe, Spawn(altitude=100.0, rotors_spinning=False))
    run(plant, 0.5)
    g = airframe.gravity
    assert plant.state[VELOCITY][2] == pytest.approx(g * 0.5, rel=1e-6)
    assert plant.state[POSITION][2] == pytest.approx(-100 + 0.5 * g * 0.25, rel=1e-6)
    assert plant.specific_force == pytest.approx([0, 0, 0], abs=1e-9)  # free fall: the IMU reads zero


def test_at_hover_trim_it_stays(airframe):
    plant = Plant(airframe, Spawn(altitude=100.0))
    run(plant, 1.0)
    assert np.abs(plant.state[VELOCITY]).max() < 0.1
    assert plant.specific_force == pytest.approx([0, 0, -airframe.gravity], abs=1e-6)


def test_on_the_ground_disarmed_it_stays_put(airframe):
    plant = Plant(airframe, Spawn())
    start = plant.state.copy()
    run(plant, 2.0)
    assert np.abs(plant.state[POSITION] - start[POSITION]).max() < 1e-4
    assert np.abs(plant.state[VELOCITY]).max() < 1e-4
    assert plant.on_ground[0] == 1.0


def test_actuator_dynamics_motor_first_order_servo_slew_limited(airframe):
    plant = Plant(airframe, Spawn(altitude=100.0))
    command = hover_command(airframe)
    command[4:8] = math.radians(90)
    run(plant, 0.5, command)
    # 60 deg/s slew limit: after 0.5 s the tilt has moved at most 30 deg.
    assert math.degrees(plant.state[TILT][0]) == pytest.approx(30.0, abs=0.5)
    stopped = Plant(airframe, Spawn(altitude=100.0))
    run(stopped, airframe.motor_tau_down, np.zeros(12))
    omega_hover = math.sqrt(airframe.hover_thrust_per_rotor / airframe.thrust_coefficient)
    assert stopped.state[ROTOR_SPEED][0] == pytest.approx(omega_hover * math.exp(-1), rel=0.01)


def test_rotor_off_gives_no_thrust_and_ok_restores_it(airframe):
    plant = Plant(airframe, Spawn(altitude=100.0))
    plant.inject_failure(101, 1, 1, float("nan"))
    assert plant.state[ROTOR_SPEED][0] == 0.0
    run(plant, 0.2)
    assert plant.state[ROTOR_SPEED][0] == 0.0
    assert plant.state[ROTOR_SPEED][1] > 800  # the others still spin
    plant.inject_failure(101, 0, 1, float("nan"))
    run(plant, 0.2)
    assert plant.state[ROTOR_SPEED][0] > 800


def test_stuck_servo_keeps_its_tilt_whatever_is_commanded(airframe):
    plant = Plant(airframe, Spawn(altitude=100.0))
    plant.inject_failure(102, 2, 1, 60.0)
    command = hover_command(airframe)
    command[4:8] = math.radians(10)
    run(plant, 2.0, command)
    assert math.degrees(plant.state[TILT][0]) == pytest.approx(60.0, abs=1e-6)  # drove to 60 and holds
    assert math.degrees(plant.state[TILT][1]) == pytest.approx(10.0, abs=0.01)
    plant.inject_failure(102, 0, 1, float("nan"))
    run(plant, 1.5)
    assert math.degrees(plant.state[TILT][0]) == pytest.approx(10.0, abs=0.01)


def test_servo_stuck_where_it_is_and_wrong_slew(airframe):
    plant = Plant(airframe, Spawn(altitude=100.0))
    command = hover_command(airframe)
    command[4:8] = math.radians(40)
    run(plant, 0.3, command)
    here = plant.state[TILT][2]
    plant.inject_failure(102, 2, 3, float("nan"))
    plant.inject_failure(102, 4, 4, 0.5)  # servo 4 at half its slew rate
    start4 = plant.state[TILT][3]
    run(plant, 0.1)
    assert plant.state[TILT][2] == here
    assert math.degrees(plant.state[TILT][3] - start4) == pytest.approx(3.0, abs=0.1)  # 30 deg/s for 0.1 s


def test_limited_rotor_and_weak_surface(airframe):
    plant = Plant(airframe, Spawn(altitude=100.0))
    plant.inject_failure(101, 4, 2, 0.3)
    command = hover_command(airframe)
    command[8:12] = (1, -1, 1, 1)
    plant.inject_failure(102, 4, 8, 0.2)  # rudder at 20 % effectiveness
    run(plant, 0.5, command)
    fraction = (plant.state[ROTOR_SPEED][1] / airframe.rotor_speed_max) ** 2
    assert fraction == pytest.approx(0.3, abs=1e-3)
    assert plant.state[SURFACE][3] == pytest.approx(1.0, abs=1e-3)  # the surface moves, its moment is scaled
    assert plant.failures.parameters[24 + 11] == 0.2


def test_stuck_surface_takes_degrees(airframe):
    plant = Plant(airframe, Spawn(altitude=100.0))
    plant.inject_failure(102, 2, 7, 15.0)  # elevator stuck at 15 deg = half of its 30 deg range
    run(plant, 0.5)
    assert plant.state[SURFACE][2] == pytest.approx(0.5, abs=1e-3)


@pytest.mark.parametrize(
    "params, unsupported",
    [
        ((101, 1, 5, float("nan")), False),  # instance out of range
        ((102, 2, 1, 120.0), False),  # tilt beyond the servo range
        ((102, 2, 9, 0.0), False),  # servo instance 9 does not exist
        ((101, 4, 1, 1.5), False),  # fraction above 1
        ((101, 1.5, 1, 0.0), False),  # type not an integer
        ((103, 1, 1, 0.0), True),  # unknown unit
        ((101, 3, 1, 0.0), True),  # GARBAGE: not simulated
        ((float("nan"), 1, 1, 0.0), False),
    ],
)
def test_bad_injections_are_refused_and_change_nothing(airframe, params, unsupported):
    plant = Plant(airframe, Spawn(altitude=100.0))
    before = plant.failures.parameters.copy(), plant.state.copy()
    with pytest.raises(FailureRejected) as refusal:
        plant.inject_failure(*params)
    assert refusal.value.unsupported == unsupported
    assert np.array_equal(before[0], plant.failures.parameters) and np.array_equal(before[1], plant.state)
