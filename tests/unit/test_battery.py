"""The simulated battery and its failsafe without processes (docs/failsafes.md, "Low battery"): PX4's SITL battery
(SIM_BAT_DRAIN, SIM_BAT_MIN_PCT, full again when disarmed), its state of charge and warning levels (BAT_LOW_THR,
BAT_CRIT_THR, BAT_EMERGEN_THR), and what COM_LOW_BAT_ACT does at each level."""

from __future__ import annotations

import pytest

from autopilot.commander.battery_simulator import (
    BatterySimulator,
    cell_voltage,
    drained,
    state_of_charge,
    warning_level,
)
from autopilot.commander.commander import build_commander
from autopilot.navigator.modes.hold import HOLD
from autopilot.navigator.modes.land import LAND
from autopilot.navigator.modes.rtl import RETURN
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.battery import BatteryWarning
from tests.unit.test_failsafes import HOME, HOVER, fly, flying_commander, state_at
from transport.mavlink import mavlink as M

TICK_USEC = 10_000


def test_the_charge_drains_with_the_time_armed_down_to_its_minimum():
    assert drained(1.0, 6.0, 60.0, 50.0) == pytest.approx(0.9)
    assert drained(0.55, 6.0, 60.0, 50.0) == 0.5
    assert cell_voltage(1.0) == 4.05 and cell_voltage(0.0) == 3.6
    assert state_of_charge(cell_voltage(0.3)) == pytest.approx(0.3)
    assert state_of_charge(5.0) == 1.0 and state_of_charge(3.0) == 0.0
    levels = [warning_level(r, 0.15, 0.07, 0.05) for r in (0.5, 0.14, 0.06, 0.04)]
    assert levels == [BatteryWarning.NONE, BatteryWarning.LOW, BatteryWarning.CRITICAL, BatteryWarning.EMERGENCY]


def run(battery: BatterySimulator, start_s: float, end_s: float, armed: bool):
    status = battery.status
    for k in range(int(round(start_s * 100)), int(round(end_s * 100)) + 1):
        status = battery.update(k * TICK_USEC, armed)
    return status


def test_px4s_default_sitl_battery_halves_in_half_a_minute_and_is_full_again_when_disarmed():
    battery = BatterySimulator(ParameterStore(None))
    assert run(battery, 0.0, 15.0, armed=True).remaining == pytest.approx(0.75 + 1 / 60, abs=0.01)  # 1 s filter lag
    status = run(battery, 15.01, 60.0, armed=True)
    assert battery.charge == 0.5 and status.remaining == pytest.approx(0.5, abs=1e-6)
    assert status.voltage_v == pytest.approx(4 * 3.825) and status.warning == BatteryWarning.NONE
    status = run(battery, 60.01, 70.0, armed=False)
    assert battery.charge == 1.0 and status.remaining == pytest.approx(1.0, abs=1e-3)


def test_the_warning_waits_for_the_estimate_to_settle():
    params = ParameterStore(None)
    params.set("SIM_BAT_MIN_PCT", 0.0)
    params.set("SIM_BAT_DRAIN", 1.0)
    params.set("BAT_LOW_THR", 0.5)
    battery = BatterySimulator(params)
    early = run(battery, 0.0, 1.99, armed=True)
    assert early.remaining < 0.5 and early.warning == BatteryWarning.NONE  # below the threshold, but PX4 waits 2 s
    assert run(battery, 2.0, 2.0, armed=True).warning == BatteryWarning.LOW


def drain_fast(**params: float):
    """A commander hovering in Hold whose battery empties in 20 s: its estimate, a second behind, is below 15 %
    (low) 18 s after arming, below 7 % (critical) at 19.6 s, below 5 % (emergency) at 20 s."""
    commander, said = flying_commander(SIM_BAT_DRAIN=20.0, SIM_BAT_MIN_PCT=0.0, **params)
    return commander, said


@pytest.mark.parametrize("action, modes", [(0, (HOLD, HOLD)), (1, (RETURN, RETURN)), (2, (LAND, LAND)),
                                           (3, (RETURN, LAND))])  # fmt: skip
def test_com_low_bat_act_acts_at_the_critical_and_emergency_levels(action, modes):
    commander, said = drain_fast(COM_LOW_BAT_ACT=action)
    fly(commander, 0.0, 17.9)
    assert said == []
    fly(commander, 17.9, 18.2)
    assert said == ["Low battery", "Low battery level, return advised"] and commander.mode == HOLD
    fly(commander, 18.2, 19.8)
    assert "Critical battery" in said and commander.mode == modes[0]
    fly(commander, 19.8, 20.5)
    assert "Emergency battery level" in said and commander.mode == modes[1]
    if action == 0:
        assert "Critical battery level, land now" in said
        assert "Emergency battery level, land immediately" in said
    else:
        assert f"Failsafe activated: {modes[0]}" in said


def on_ground(commander, start_s: float, end_s: float) -> None:
    for k in range(int(round(start_s * 100)) + 1, int(round(end_s * 100)) + 1):
        commander.tick(state_at(k / 100, down=0.0), k * TICK_USEC, 0.0)


def test_armed_on_the_ground_the_levels_only_warn_and_disarmed_they_follow_the_battery():
    params = ParameterStore(None)
    for name, value in (("SIM_BAT_DRAIN", 20.0), ("SIM_BAT_MIN_PCT", 0.0), ("COM_LOW_BAT_ACT", 2),
                        ("COM_DISARM_PRFLT", -1.0)):  # fmt: skip
        params.set(name, value)
    said: list[str] = []
    commander = build_commander(params, HOVER, armed=True, in_air=False, home=HOME,
                                say=lambda severity, text, key=None: said.append(text))  # fmt: skip
    commander.start(state_at(0.0, down=0.0))
    on_ground(commander, 0.0, 20.5)
    assert commander.armed and commander.mode == HOLD
    assert said == ["Low battery", "Low battery level, return advised", "Critical battery",
                    "Critical battery level, land now", "Emergency battery level",
                    "Emergency battery level, land immediately"]  # fmt: skip
    assert commander.disarm(state_at(20.5, down=0.0))[0] == M.MAV_RESULT_ACCEPTED
    on_ground(commander, 20.5, 26.0)
    assert commander.failsafe.battery_warning == BatteryWarning.NONE and commander.report().battery.remaining > 0.99
