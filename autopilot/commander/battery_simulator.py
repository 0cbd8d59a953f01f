"""The simulated battery, as PX4's SITL has it (its simulation/battery_simulator module and lib/battery): a charge
that drains linearly with the time armed, SIM_BAT_DRAIN seconds from full to empty, but not below SIM_BAT_MIN_PCT,
and is full again whenever the vehicle is disarmed; the pack's voltage from the charge between the cells' empty
and charged voltages; the state of charge estimated from the voltage through PX4's 1 s filter; the warning level
from BAT_LOW_THR, BAT_CRIT_THR and BAT_EMERGEN_THR once the estimate has settled (2 s after the start).

Updated at the commander's 100 Hz, in simulation time.
"""

from __future__ import annotations

from autopilot.storage.parameters import ParameterStore
from autopilot.topics.battery import CELL_CHARGED_V, CELL_EMPTY_V, CELLS, FULL, BatteryStatus, BatteryWarning

FILTER_TIME_CONSTANT_S = 1.0  # PX4's cell-voltage filter
SETTLING_USEC = 2_000_000  # PX4 judges the warning level only this long after the battery connected


def drained(charge: float, dt_s: float, drain_s: float, min_percent: float) -> float:
    """The charge (0..1) after `dt_s` armed: down by dt / SIM_BAT_DRAIN, not below SIM_BAT_MIN_PCT."""
    return max(charge - dt_s / drain_s, min_percent / 100.0)


def cell_voltage(charge: float) -> float:
    """A cell's voltage (V) at `charge`, linear between empty and charged."""
    return CELL_EMPTY_V + (CELL_CHARGED_V - CELL_EMPTY_V) * charge


def state_of_charge(cell_voltage_v: float) -> float:
    """PX4's voltage-based state of charge (0..1) of a cell voltage (no load: the simulated battery has no current)."""
    return min(max((cell_voltage_v - CELL_EMPTY_V) / (CELL_CHARGED_V - CELL_EMPTY_V), 0.0), 1.0)


def warning_level(remaining: float, low: float, critical: float, emergency: float) -> BatteryWarning:
    """PX4's determineWarning: the worst threshold the state of charge is below."""
    if remaining < emergency:
        return BatteryWarning.EMERGENCY
    if remaining < critical:
        return BatteryWarning.CRITICAL
    if remaining < low:
        return BatteryWarning.LOW
    return BatteryWarning.NONE


class BatterySimulator:
    def __init__(self, params: ParameterStore) -> None:
        self.params = params
        self.charge = 1.0
        self.filtered_cell_v = CELL_CHARGED_V
        self.status = FULL
        self._start_usec: int | None = None
        self._last_usec: int | None = None

    def restart(self) -> None:
        """A new plant run: time starts again (the charge stays)."""
        self._start_usec = self._last_usec = None

    def update(self, now_usec: int, armed: bool) -> BatteryStatus:
        if self._start_usec is None or self._last_usec is None:
            self._start_usec = self._last_usec = now_usec
        dt_s = max(now_usec - self._last_usec, 0) / 1e6
        self._last_usec = now_usec
        params = self.params
        if armed:
            self.charge = drained(self.charge, dt_s, params["SIM_BAT_DRAIN"], params["SIM_BAT_MIN_PCT"])
        else:
            self.charge = 1.0
        cell_v = cell_voltage(self.charge)
        self.filtered_cell_v += (cell_v - self.filtered_cell_v) * dt_s / (dt_s + FILTER_TIME_CONSTANT_S)
        remaining = state_of_charge(self.filtered_cell_v)
        warning = BatteryWarning.NONE
        if now_usec - self._start_usec >= SETTLING_USEC:
            warning = warning_level(remaining, params["BAT_LOW_THR"], params["BAT_CRIT_THR"], params["BAT_EMERGEN_THR"])
        self.status = BatteryStatus(cell_v * CELLS, CELLS, remaining, warning)
        return self.status
