"""The battery as PX4's battery_status topic has it: voltage, state of charge and the warning level, for the
failsafes (autopilot/commander/failsafe.py) and for SYS_STATUS and BATTERY_STATUS."""

from __future__ import annotations

import enum
from dataclasses import dataclass


class BatteryWarning(enum.IntEnum):
    """PX4's battery_status.warning levels (BAT_LOW_THR, BAT_CRIT_THR, BAT_EMERGEN_THR), in order of severity."""

    NONE = 0
    LOW = 1
    CRITICAL = 2
    EMERGENCY = 3


@dataclass(frozen=True)
class BatteryStatus:
    voltage_v: float
    cell_count: int
    remaining: float  # state of charge, 0..1
    warning: BatteryWarning

    @property
    def cell_voltage_v(self) -> float:
        return self.voltage_v / self.cell_count


CELLS = 4  # PX4 SITL's battery: 4S (BAT1_N_CELLS), 3.6 V empty and 4.05 V charged a cell (BAT1_V_EMPTY, _CHARGED)
CELL_EMPTY_V, CELL_CHARGED_V = 3.6, 4.05
FULL = BatteryStatus(CELLS * CELL_CHARGED_V, CELLS, 1.0, BatteryWarning.NONE)
