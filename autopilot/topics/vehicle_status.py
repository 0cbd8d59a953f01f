"""The vehicle's status snapshot: what the flight stack publishes once per plant step for the MAVLink services.

The services (autopilot/mavlink/) read only this: arming, mode, landed and VTOL state, the state estimate, the
position as the GPS sees it, home as the commander keeps it (HOME_POSITION, relative altitudes), the actuator
outputs, the controller flying, the failures known, the stored missions and their progress (MISSION_CURRENT,
MISSION_ITEM_REACHED, downloads), and what happened since the last snapshot (events to announce, failure
injections answered by the plant). As PX4's mavlink streams read vehicle_status and friends, never the commander.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np

from aircraft.failures import Failure
from autopilot.topics.battery import FULL as FULL_BATTERY
from autopilot.topics.battery import BatteryStatus
from autopilot.topics.flight_mode import ModeId
from autopilot.topics.home_position import HomePosition
from autopilot.topics.missions import EMPTY as NO_MISSIONS
from autopilot.topics.missions import Missions
from autopilot.topics.sensor_sample import SensorSample
from autopilot.topics.vehicle_state import VehicleState
from transport.mavlink import mavlink

T = TypeVar("T")
MC_TILT_MAX = math.radians(5.0)  # mean tilt below this: multicopter
FW_TILT_MIN = math.radians(85.0)  # mean tilt above this: fixed wing


@dataclass(frozen=True)
class CommanderReport:
    """The commander's part of the vehicle status."""

    started: bool
    armed: bool
    mode: ModeId
    landed_state: int
    flying: bool
    state_version: int
    terminated: bool
    battery: BatteryStatus = FULL_BATTERY


@dataclass(frozen=True)
class Event:
    """Something to announce (STATUSTEXT). With a key, the same refusal is said at most once a second."""

    severity: int
    text: str
    key: str | None = None


@dataclass(frozen=True)
class InjectionOutcome:
    """The plant's answer to a failure injection a ground station asked for (ticket from InjectFailure)."""

    ticket: int
    result: int  # MAV_RESULT
    text: str


@dataclass(frozen=True)
class GlobalPosition:
    """Position and velocity as the plant's HIL_STATE_QUATERNION gives them (degE7, mm AMSL, cm/s NED)."""

    lat_e7: int
    lon_e7: int
    alt_mm: int
    vn_cms: int
    ve_cms: int
    vd_cms: int


@dataclass(frozen=True, slots=True)
class VehicleStatus:
    time_usec: int
    started: bool
    armed: bool
    mode: ModeId  # the commander's mode: its name and PX4 custom mode
    landed_state: int  # MAV_LANDED_STATE
    flying: bool  # armed and off the ground: the flight controller runs
    vtol_state: int  # MAV_VTOL_STATE
    state_version: int  # changes with every arming, mode or ground-state change (a HEARTBEAT is due)
    estimate: VehicleState
    position: GlobalPosition
    home: HomePosition  # the commander's (replaced on every change: a new object is a new home)
    pwm: tuple[int, ...]  # the 12 channels sent to the plant this step
    throttle_percent: int
    controller: str  # the velocity controller flying: "mpc" or "pid"
    failures: tuple[Failure, ...] = ()  # known to the controllers
    motors_failed: tuple[int, ...] = ()  # 0-based motors the failure detector found failed (this flight)
    servos_jammed: tuple[int, ...] = ()  # 0-based tilt servos the failure detector found jammed (this flight)
    events: tuple[Event, ...] = ()  # since the last snapshot
    injections: tuple[InjectionOutcome, ...] = ()  # answered since the last snapshot
    missions: Missions = NO_MISSIONS  # stored mission, fence, rally; current item, state, last reached (immutable)
    terminated: bool = False  # flight termination (a failsafe or DO_FLIGHTTERMINATION): motors off until cleared
    sensors: SensorSample | None = None  # the simulated sensors this step, calibrated (None before the plant sent any)
    battery: BatteryStatus = FULL_BATTERY  # the simulated battery (autopilot/commander/battery_simulator.py)

    @property
    def time_boot_ms(self) -> int:
        return (self.time_usec // 1000) & 0xFFFFFFFF


def vtol_state(tilt_estimate: np.ndarray, tilt_command: np.ndarray) -> int:
    """MAV_VTOL_STATE from the rotors' mean tilt (rad) and where the tilt command takes them. Plain Python: every
    plant step builds a status."""
    estimate = tilt_estimate.tolist()
    mean = sum(estimate) / len(estimate)
    if mean < MC_TILT_MAX:
        return mavlink.MAV_VTOL_STATE_MC
    if mean > FW_TILT_MIN:
        return mavlink.MAV_VTOL_STATE_FW
    command = tilt_command.tolist()
    if sum(command) / len(command) >= mean:
        return mavlink.MAV_VTOL_STATE_TRANSITION_TO_FW
    return mavlink.MAV_VTOL_STATE_TRANSITION_TO_MC


def copy_state(state: VehicleState) -> VehicleState:
    """A copy of the estimate that the next step's update does not change."""
    return VehicleState(state.time_usec, state.position_ned.copy(), state.velocity_ned.copy(), state.quaternion.copy(),
                        state.euler.copy(), state.body_rates.copy(), state.airspeed, state.specific_force.copy(),
                        state.valid)  # fmt: skip


@dataclass
class EventOutbox:
    """Events said by the flight stack's parts during a step, collected for the next snapshot."""

    pending: list[Event] = field(default_factory=list)

    def say(self, severity: int, text: str, key: str | None = None) -> None:
        self.pending.append(Event(severity, text, key))

    def drain(self) -> tuple[Event, ...]:
        return drain(self.pending)


def drain(items: list[T]) -> tuple[T, ...]:
    """What a list collected since the last snapshot, emptying it (no allocation when it is empty)."""
    if not items:
        return ()
    taken = tuple(items)
    items.clear()
    return taken
