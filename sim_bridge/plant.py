"""The simulated vehicle: state, commands, failures and the compiled RK4 step, without any I/O."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aircraft.actuators import ROTORS
from aircraft.airframe import Airframe
from aircraft.codegen import compiled
from aircraft.failures import FailureType, FailureUnit, parse_failure
from sim_bridge.dynamics import (
    COMMAND_SIZE,
    POSITION,
    QUATERNION,
    ROTOR_SPEED,
    STATE_SIZE,
    WIND,
    build_output_function,
    build_step_function,
)
from sim_bridge.failures import ActuatorFailures, apply_failure, healthy_parameters
from sim_bridge.ground import resting_height
from sim_bridge.wind import WindModel

DT = 1.0 / 400.0  # s, the plant link's step (docs/plant-link.md)
DT_USEC = 2500


@dataclass(frozen=True)
class Spawn:
    """Initial condition: on the ground (altitude None) or hovering at `altitude` m above home."""

    altitude: float | None = None
    rotors_spinning: bool = True  # when hovering: rotors at hover trim (True) or stopped (False)
    yaw_deg: float = 0.0


def hover_command(airframe: Airframe) -> np.ndarray:
    """Command that holds a level hover at zero tilt: every rotor at m g / 4."""
    command = np.zeros(COMMAND_SIZE)
    command[ROTORS] = airframe.hover_thrust_per_rotor / airframe.thrust_max
    return command


def initial_state(airframe: Airframe, spawn: Spawn) -> np.ndarray:
    """State vector for a spawn condition."""
    state = np.zeros(STATE_SIZE)
    half_yaw = math.radians(spawn.yaw_deg) / 2
    state[QUATERNION] = (math.cos(half_yaw), 0.0, 0.0, math.sin(half_yaw))
    if spawn.altitude is None:
        state[POSITION] = (0.0, 0.0, resting_height(airframe))
    else:
        state[POSITION] = (0.0, 0.0, -spawn.altitude)
        if spawn.rotors_spinning:
            state[ROTOR_SPEED] = math.sqrt(airframe.hover_thrust_per_rotor / airframe.thrust_coefficient)
    return state


class Plant:
    """One vehicle in simulation: `step()` advances it by DT with the current command, failures and wind."""

    def __init__(
        self,
        airframe: Airframe,
        spawn: Spawn,
        compile_model: bool = True,
        wind: WindModel | None = None,
    ) -> None:
        """`wind`: the wind model (mean and turbulence, sim_bridge/wind.py); None: still air."""
        self.airframe = airframe
        self.step_count = 0
        self.state = initial_state(airframe, spawn)
        hovering = spawn.altitude is not None and spawn.rotors_spinning
        self.command = hover_command(airframe) if hovering else np.zeros(COMMAND_SIZE)
        self.wind = wind if wind is not None else WindModel()
        self.failures = ActuatorFailures(parameters=healthy_parameters(tuple(self.wind.mean_ned)))
        self.failed_sensors: set[FailureUnit] = set()  # OFF: the sensor suite stops sending what it measures
        self.specific_force = np.zeros(3)
        self.airspeed = np.zeros(1)
        self.on_ground = np.zeros(1)
        self._next_state = np.zeros(STATE_SIZE)
        step_function = build_step_function(airframe, DT)
        self._function = compiled(step_function, "vtol-sim") if compile_model else step_function
        # The buffer interface evaluates the CasADi function on these numpy arrays without conversions.
        self._buffer, self._evaluate = self._function.buffer()
        self._bind(self.state)
        self._buffer.set_arg(1, memoryview(self.command))
        self._buffer.set_arg(2, memoryview(self.failures.parameters))
        self._buffer.set_res(0, memoryview(self._next_state))
        self._buffer.set_res(1, memoryview(self.specific_force))
        self._buffer.set_res(2, memoryview(self.airspeed))
        self._buffer.set_res(3, memoryview(self.on_ground))
        specific_force, airspeed, on_ground = build_output_function(airframe)(
            self.state, self.command, self.failures.parameters
        )
        self.specific_force[:] = np.asarray(specific_force).ravel()
        self.airspeed[:] = float(airspeed)
        self.on_ground[:] = float(on_ground)

    def _bind(self, state: np.ndarray) -> None:
        self._buffer.set_arg(0, memoryview(state))

    @property
    def time_usec(self) -> int:
        """Simulation time of the current state, t_k = k dt, in microseconds."""
        return self.step_count * DT_USEC

    def set_command(self, command: np.ndarray) -> None:
        """Physical command (thrust fractions, tilts rad, deflections) held until the next call."""
        self.command[:] = command

    def step(self) -> None:
        """Advance one RK4 step of DT with the held command, in the wind of this step."""
        self.failures.parameters[WIND] = self.wind.step(DT)
        self._evaluate()
        self.state[:] = self._next_state
        self.step_count += 1

    def inject_failure(self, unit: float, kind: float, instance: float, extra: float) -> list[str]:
        """Apply a MAV_CMD_INJECT_FAILURE (param1..param4) at once; raises FailureRejected for bad requests.

        Returns one line per affected actuator (or the sensor), as the plant announces it."""
        failure = parse_failure(unit, kind, instance, extra)
        if failure.sensor:
            if failure.kind == FailureType.OFF:
                self.failed_sensors.add(failure.unit)
            else:
                self.failed_sensors.discard(failure.unit)
            return [failure.describe()]
        return apply_failure(self.failures, self.airframe, self.state, failure)
