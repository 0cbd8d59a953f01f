"""Without a C compiler the PID vehicle flies on CasADi's virtual machine (the plant's RK4, the allocator's QP data
and achieved wrench, the attitude loop): the same flight, to the last bit of every command."""

from __future__ import annotations

import numpy as np

from aircraft.actuators import command_to_pwm
from aircraft.airframe import Airframe
from autopilot.controllers import PID, build_flight_controller
from autopilot.topics.vehicle_state import VehicleState, euler_from_quaternion
from scenarios.profiles import accel
from sim_bridge.plant import Plant, Spawn

SECONDS = 1.5


def fly(airframe: Airframe) -> tuple[np.ndarray, list[list[int]]]:
    """The PID closed loop on the accel profile at 400 Hz: every step's 12 commands and PWM."""
    plant = Plant(airframe, Spawn(altitude=100.0))
    controller = build_flight_controller(airframe, PID)
    state = VehicleState()
    commands, pwm = [], []
    for _ in range(int(SECONDS * 400)):
        x = plant.state
        state.time_usec = plant.time_usec
        state.position_ned[:], state.velocity_ned[:], state.quaternion[:] = x[0:3], x[3:6], x[6:10]
        state.euler[:] = euler_from_quaternion(*x[6:10].tolist())
        state.body_rates[:] = x[10:13]
        state.specific_force[:] = plant.specific_force
        state.airspeed, state.valid = float(plant.airspeed[0]), True
        if controller.velocity_due(state.time_usec):
            controller.set_velocity_setpoint(accel(state.time_s))
        controller.step(state)
        commands.append(controller.command.copy())
        pwm.append(command_to_pwm(airframe, controller.command))
        plant.set_command(controller.command)
        plant.step()
    return np.array(commands), pwm


def test_without_a_compiler_the_pid_vehicle_flies_the_same(airframe, tmp_path, monkeypatch, capsys) -> None:
    compiled_commands, compiled_pwm = fly(airframe)
    monkeypatch.setenv("TILTROTOR_SITL_CACHE", str(tmp_path))  # nothing cached: it would have to compile
    monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    interpreted_commands, interpreted_pwm = fly(airframe)
    assert "virtual machine" in capsys.readouterr().err  # the fall-back was taken, and said
    assert interpreted_pwm == compiled_pwm
    assert np.array_equal(interpreted_commands, compiled_commands)
