"""The commander's rules in simulation time, without processes: arming checks, mode entry, the Offboard loss
failsafe, takeoff to Hold, touchdown and the automatic disarms (docs/mavlink.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.commander.commander import ACCEPTED, DENIED, TEMPORARILY_REJECTED, Commander, build_commander
from autopilot.commander.guided_requests import GuidedRequests
from autopilot.navigator.modes import MODES
from autopilot.navigator.modes.hold import HOLD
from autopilot.navigator.modes.land import LAND
from autopilot.navigator.modes.offboard import OFFBOARD
from autopilot.navigator.modes.takeoff import TAKEOFF
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.vehicle_state import VehicleState
from transport.mavlink import mavlink as M

HOVER = 0.69


def state_at(t_s: float, down: float = 0.0, velocity=(0.0, 0.0, 0.0), roll: float = 0.0) -> VehicleState:
    state = VehicleState(time_usec=int(round(t_s * 1e6)), valid=True)
    state.position_ned[:] = (0.0, 0.0, down)
    state.velocity_ned[:] = velocity
    state.euler[0] = roll
    return state


def new_commander(in_air: bool = False, **params) -> tuple[Commander, list[str]]:
    store = ParameterStore(None)
    for name, value in params.items():
        store.set(name, value)
    said: list[str] = []
    commander = build_commander(store, HOVER, armed=in_air, in_air=in_air, say=lambda severity, text: said.append(text))
    commander.start(state_at(0.0, down=-50.0 if in_air else 0.0))
    return commander, said


IDS = {kind.id.name: kind.id for kind in MODES}


def custom_mode(mode: str) -> int:
    return IDS[mode].custom_mode


def mode_from_px4(main: int, sub: int) -> str | None:
    """As the MAVLink services pick a mode for SET_MODE: the first of the table that matches."""
    return next((kind.id.name for kind in MODES if kind.id.matches(main, sub)), None)


def test_px4_custom_modes_round_trip():
    assert custom_mode(HOLD) == (4 << 16) | (3 << 24) and custom_mode(OFFBOARD) == 6 << 16
    for mode in (HOLD, TAKEOFF, LAND, OFFBOARD):
        value = custom_mode(mode)
        assert mode_from_px4((value >> 16) & 0xFF, (value >> 24) & 0xFF) == mode
    assert mode_from_px4(3, 0) == "Position" and mode_from_px4(2, 0) == "Altitude" and mode_from_px4(4, 4) == "Mission"
    assert mode_from_px4(1, 0) is None  # MANUAL (no RC, no stabilised modes)


def test_arming_checks_and_disarming_in_the_air():
    commander, _ = new_commander()
    assert commander.arm(state_at(0.0, roll=math.radians(45)))[0] == DENIED
    assert commander.arm(state_at(0.0))[0] == ACCEPTED and commander.armed and not commander.flying
    assert commander.disarm(state_at(0.0))[0] == ACCEPTED and not commander.armed
    flying, _ = new_commander(in_air=True)
    result, reason = flying.disarm(state_at(0.0, -50.0))
    assert result == DENIED and "21196" in reason
    assert flying.disarm(state_at(0.0, -50.0), force=True)[0] == ACCEPTED and not flying.armed


def test_offboard_needs_a_fresh_set_point_and_fails_safe_to_hold_after_com_of_loss_t():
    commander, said = new_commander(in_air=True, COM_OF_LOSS_T=0.5)
    state = state_at(1.0, -50.0)
    commander.tick(state, state.time_usec, HOVER)
    assert commander.set_mode(OFFBOARD, state)[0] == TEMPORARILY_REJECTED
    commander.offboard.receive(np.array([3.0, 0.0, 0.0]), None, commander.now_usec)
    assert commander.set_mode(OFFBOARD, state)[0] == ACCEPTED and commander.mode == OFFBOARD
    t = 1.0
    while commander.mode == OFFBOARD:
        t += 0.01
        setpoint = commander.tick(state_at(t, -50.0), int(round(t * 1e6)), HOVER)
        if commander.mode == OFFBOARD:
            assert list(setpoint) == [3.0, 0.0, 0.0]
    assert t == pytest.approx(1.5, abs=0.011)  # Hold once the last set-point is COM_OF_LOSS_T old
    assert commander.mode == HOLD and any("Offboard lost" in text for text in said)
    assert commander.state_changed  # a HEARTBEAT goes out now


def test_takeoff_climbs_to_the_altitude_then_holds_there():
    commander, said = new_commander(MIS_TAKEOFF_ALT=10.0)
    assert commander.takeoff(state_at(0.0), None)[0] == ACCEPTED and commander.mode == TAKEOFF
    assert not commander.flying  # disarmed: waiting for arming
    commander.arm(state_at(0.0))
    setpoint = commander.tick(state_at(0.01), 10_000, HOVER)  # lifts off at the next 100 Hz tick
    assert commander.flying and commander.controller_reset
    assert setpoint[2] == pytest.approx(-1.5)  # MPC_TKO_SPEED
    assert commander.landed_state == M.MAV_LANDED_STATE_TAKEOFF
    setpoint = commander.tick(state_at(5.0, down=-9.8), 5_000_000, HOVER)
    assert commander.mode == HOLD and "Takeoff complete: Hold" in said
    assert setpoint[2] == pytest.approx(-0.2)  # holds the takeoff altitude (P on the 0.2 m left)
    assert commander.landed_state == M.MAV_LANDED_STATE_IN_AIR


def test_land_detects_touchdown_and_disarms_after_com_disarm_land():
    commander, said = new_commander(in_air=True, COM_DISARM_LAND=1.0)
    assert GuidedRequests(commander).land(state_at(0.0, -50.0))[0] == ACCEPTED
    assert commander.tick(state_at(0.01, -50.0), 10_000, HOVER)[2] == pytest.approx(1.5)  # MPC_Z_VEL_MAX_DN
    assert commander.tick(state_at(0.02, -3.0), 20_000, HOVER)[2] == pytest.approx(0.7)  # below MPC_LAND_ALT2
    t = 1.0
    while commander.flying:  # on the ground: stopped, thrust unloading
        t += 0.01
        commander.tick(state_at(t, -0.2), int(round(t * 1e6)), 0.4 * HOVER)
    assert t == pytest.approx(1.5, abs=0.02) and "Landing detected" in said and commander.armed
    while commander.armed:
        t += 0.01
        commander.tick(state_at(t, -0.2), int(round(t * 1e6)), 0.0)
    assert t == pytest.approx(2.5, abs=0.02) and "Disarmed after landing" in said
    assert commander.landed_state == M.MAV_LANDED_STATE_ON_GROUND


def test_armed_on_the_ground_without_a_takeoff_disarms_after_com_disarm_prflt():
    commander, said = new_commander(COM_DISARM_PRFLT=2.0)
    commander.arm(state_at(0.0))
    t = 0.0
    while commander.armed:
        t += 0.01
        assert commander.tick(state_at(t), int(round(t * 1e6)), 0.0) is None
    assert t == pytest.approx(2.0, abs=0.02) and any("no takeoff" in text for text in said)


def test_the_transition_command_in_hold_circles_and_comes_back_to_a_hover():
    commander, _ = new_commander(in_air=True)
    guided = GuidedRequests(commander)
    state = state_at(0.0, -50.0)
    assert guided.transition(7, state)[0] == DENIED
    assert guided.transition(M.MAV_VTOL_STATE_FW, state)[0] == ACCEPTED
    setpoint = commander.tick(state_at(0.01, -50.0), 10_000, HOVER)
    assert math.hypot(setpoint[0], setpoint[1]) == pytest.approx(26.0)  # FW_AIRSPD_TRIM
    assert guided.transition(M.MAV_VTOL_STATE_MC, state)[0] == ACCEPTED
    moving = state_at(0.02, -50.0, velocity=(20.0, 0.0, 0.0))
    assert list(commander.tick(moving, 20_000, HOVER)[0:2]) == [0.0, 0.0]  # brake first
    commander.offboard.receive(np.zeros(3), None, commander.now_usec)
    commander.set_mode(OFFBOARD, state)
    assert guided.transition(M.MAV_VTOL_STATE_FW, state)[0] == TEMPORARILY_REJECTED
