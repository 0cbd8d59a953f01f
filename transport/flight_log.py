"""The autopilot's 100 Hz flight log (`vtol-autopilot --log FILE.csv`): its columns, their text formats, its one
reader and its writer.

One row per velocity-controller tick, one column per name in COLUMNS (in that order, a header row first):

    t                               s (simulation time; scenario tables: since the profile start)
    north east down, vn ve vd       truth position (m) and velocity (m/s), NED
    roll pitch yaw, p q r           truth attitude (rad) and body rates (rad/s)
    airspeed                        m/s
    vn_sp ve_sp vd_sp               velocity set-point (m/s)
    roll_sp pitch_sp yaw_sp         attitude set-point (rad)
    tilt_cmd1..4, tilt_est1..4      tilt servo commands and estimated tilts (rad)
    u1..u8                          the allocator's 8 actuators: rotor thrust fractions 1-4, then left aileron,
                                    right aileron, elevator, rudder (-1..1)
    residual_force residual_moment  norms of the allocation's residual (N, N m)
    mode                            the velocity controller's mode (text: MC, TRANSITION_FW, FW, ...)
"""

from __future__ import annotations

import csv
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO

import numpy as np

from aircraft.actuators import ALLOCATED_COUNT, ALLOCATED_ROTORS, ALLOCATED_SURFACES

T = "t"
POSITION = NORTH, EAST, DOWN = ("north", "east", "down")
VELOCITY = VN, VE, VD = ("vn", "ve", "vd")
ATTITUDE = ROLL, PITCH, YAW = ("roll", "pitch", "yaw")
BODY_RATES = ("p", "q", "r")
AIRSPEED = "airspeed"
VELOCITY_SP = VN_SP, VE_SP, VD_SP = ("vn_sp", "ve_sp", "vd_sp")
ATTITUDE_SP = ROLL_SP, PITCH_SP, YAW_SP = ("roll_sp", "pitch_sp", "yaw_sp")
TILT_CMD = tuple(f"tilt_cmd{i}" for i in range(1, 5))
TILT_EST = tuple(f"tilt_est{i}" for i in range(1, 5))
ALLOCATED = tuple(f"u{i}" for i in range(1, ALLOCATED_COUNT + 1))
THRUST = ALLOCATED[ALLOCATED_ROTORS]  # u1..u4
SURFACE = ALLOCATED[ALLOCATED_SURFACES]  # u5..u8
RESIDUAL = ("residual_force", "residual_moment")
MODE = "mode"

NUMERIC_COLUMNS: tuple[str, ...] = (
    T, *POSITION, *VELOCITY, *ATTITUDE, *BODY_RATES, AIRSPEED, *VELOCITY_SP, *ATTITUDE_SP, *TILT_CMD, *TILT_EST,
    *ALLOCATED, *RESIDUAL,
)  # fmt: skip
COLUMNS: tuple[str, ...] = (*NUMERIC_COLUMNS, MODE)
"""The header row, in order; every column but the last (MODE, text) is a number."""

TIME_FORMAT = ".4f"  # 0.1 ms
RESIDUAL_FORMAT = ".4g"
VALUE_FORMAT = ".5g"
FORMATS: dict[str, str] = {
    name: TIME_FORMAT if name == T else RESIDUAL_FORMAT if name in RESIDUAL else VALUE_FORMAT
    for name in NUMERIC_COLUMNS
}
"""Each numeric column's format spec in the file."""


def format_row(values: Sequence[float], mode: str) -> list[str]:
    """One row as text: `values` in NUMERIC_COLUMNS order, each in its column's format, then the mode."""
    if len(values) != len(NUMERIC_COLUMNS):
        raise ValueError(f"a flight-log row has {len(NUMERIC_COLUMNS)} numbers, got {len(values)}")
    return [format(float(value), FORMATS[name]) for name, value in zip(NUMERIC_COLUMNS, values)] + [mode]


@dataclass(frozen=True)
class FlightLog(Mapping[str, np.ndarray]):
    """A flight log read back: a mapping of each numeric column's name (COLUMNS) to its values, and the modes."""

    columns: dict[str, np.ndarray]
    modes: list[str]

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self.columns)

    def __len__(self) -> int:
        return len(self.columns)

    def rows(self) -> Iterator[list[float | str]]:
        """Each row: its numbers in NUMERIC_COLUMNS order, then the mode."""
        numbers = zip(*(self.columns[name].tolist() for name in NUMERIC_COLUMNS))
        return ([*values, mode] for values, mode in zip(numbers, self.modes))

    def since(self, start_s: float) -> FlightLog:
        """The rows from `start_s` on (within 1 ns), with t shifted so that `start_s` is t = 0."""
        keep = self.columns[T] - start_s >= -1e-9
        columns = {name: values[keep] for name, values in self.columns.items()}
        columns[T] = np.maximum(columns[T] - start_s, 0.0)
        return FlightLog(columns, [mode for mode, kept in zip(self.modes, keep.tolist()) if kept])


def read_flight_log(path: Path) -> FlightLog:
    """Read a flight log; ValueError if its header is not COLUMNS, a number does not parse, or it has no rows."""
    with open(path, newline="") as handle:
        reader = csv.reader(handle)
        header = tuple(next(reader, ()))
        if header != COLUMNS:
            raise ValueError(f"{path}: not a flight log (its header is not the {len(COLUMNS)} columns of "
                             "transport/flight_log.py)")  # fmt: skip
        rows = list(reader)
    if not rows:
        raise ValueError(f"{path}: empty flight log")
    for line, row in enumerate(rows, start=2):
        if len(row) != len(COLUMNS):
            raise ValueError(f"{path}:{line}: {len(row)} fields, a flight-log row has {len(COLUMNS)}")
    numbers = [[float(text) for text in row[:-1]] for row in rows]
    columns = {name: np.array(values) for name, values in zip(NUMERIC_COLUMNS, zip(*numbers))}
    return FlightLog(columns, [row[-1] for row in rows])


class FlightLogWriter:
    """Writes a flight log to an open text file: the header row at once, then one row per `write`."""

    def __init__(self, handle: IO[str]) -> None:
        self._writer = csv.writer(handle)
        self._writer.writerow(COLUMNS)

    def write(self, values: Sequence[float], mode: str) -> None:
        """One row: `values` in NUMERIC_COLUMNS order, then the mode."""
        self._writer.writerow(format_row(values, mode))


def write_flight_log(path: Path, log: FlightLog) -> None:
    """Write `log` in the file format (each number in its column's format)."""
    with open(path, "w", newline="") as handle:
        writer = FlightLogWriter(handle)
        for *values, mode in log.rows():
            writer.write(values, mode)
