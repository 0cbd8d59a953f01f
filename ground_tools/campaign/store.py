"""The campaign's store: a DuckDB file with one row per flight (its key, parameters, code version, the metrics of
docs/scenarios.md, run folder), written by the campaign's driver only, read back with DuckDB or pandas
(docs/campaigns.md). Writing a key that is there replaces its row: the same point is always one row."""

from __future__ import annotations

import datetime
import json
import math
from pathlib import Path
from typing import Any

import duckdb
import pandas

from ground_tools.metrics import METRIC_KINDS

STORE_FILE = "campaign.duckdb"
TABLE = "flights"
SQL_TYPES = {float: "DOUBLE", int: "INTEGER", bool: "BOOLEAN"}
METRICS: dict[str, str] = {name: SQL_TYPES[kind] for name, kind in METRIC_KINDS.items()}
"""The metrics' columns (ground_tools/metrics.py's keys) and their types."""
COLUMNS: dict[str, str] = {
    "key": "VARCHAR PRIMARY KEY", "campaign": "VARCHAR", "scenario": "VARCHAR", "controller": "VARCHAR",
    "repetition": "INTEGER", "params": "JSON", "status": "VARCHAR", "error": "VARCHAR", "failure_trigger": "VARCHAR",
    **METRICS, "sim_s": "DOUBLE", "wall_s": "DOUBLE", "code_version": "VARCHAR", "host": "VARCHAR",
    "run_dir": "VARCHAR", "finished_utc": "TIMESTAMP",
}  # fmt: skip


class StoreError(RuntimeError):
    """The store cannot be opened (another campaign holds it, or it is not a DuckDB file)."""


def _sql_type(value: Any) -> str:
    if isinstance(value, bool):
        return "BOOLEAN"
    return "DOUBLE" if isinstance(value, (int, float)) else "VARCHAR"


def _cell(value: Any) -> Any:
    return None if isinstance(value, float) and not math.isfinite(value) else value


class ResultStore:
    """The flights table of one campaign folder; `parameters` are its axes and fixed values, one column each."""

    def __init__(self, path: Path, read_only: bool = False) -> None:
        self.path = path
        try:
            self.db = duckdb.connect(str(path), read_only=read_only)
        except duckdb.Error as exc:
            raise StoreError(f"cannot open the store {path}: {exc}") from None
        if not read_only:
            columns = ", ".join(f'"{name}" {kind}' for name, kind in COLUMNS.items())
            self.db.execute(f"CREATE TABLE IF NOT EXISTS {TABLE} ({columns})")
            self._add_columns(METRICS)  # a store written before a metric was added gets its column

    def _columns(self) -> set[str]:
        return {row[0] for row in self.db.execute(f"SELECT column_name FROM (DESCRIBE {TABLE})").fetchall()}

    def _add_columns(self, types: dict[str, str]) -> None:
        have = self._columns()
        for name, kind in types.items():
            if name not in have:
                self.db.execute(f'ALTER TABLE {TABLE} ADD COLUMN "{name}" {kind}')

    def close(self) -> None:
        self.db.close()

    def add_parameter_columns(self, example: dict[str, Any]) -> None:
        """A column for each parameter not yet in the table, typed after `example`'s value."""
        self._add_columns({name: _sql_type(value) for name, value in example.items()})

    def finished_keys(self) -> set[str]:
        return {row[0] for row in self.db.execute(f"SELECT key FROM {TABLE} WHERE status = 'done'").fetchall()}

    def put(self, campaign: str, row: dict[str, Any]) -> None:
        """Insert the flight's row, or replace the row of its key."""
        self.add_parameter_columns(row["params"])
        cells = {name: row.get(name) for name in COLUMNS if name not in METRICS}
        cells.update(campaign=campaign, params=json.dumps(row["params"], sort_keys=True),
                     finished_utc=datetime.datetime.now(datetime.UTC).replace(tzinfo=None))  # fmt: skip
        cells.update({name: _cell(row["metrics"].get(name)) for name in METRICS})
        cells.update(row["params"])
        names = ", ".join(f'"{name}"' for name in cells)
        marks = ", ".join("?" for _ in cells)
        self.db.execute(f"INSERT OR REPLACE INTO {TABLE} ({names}) VALUES ({marks})", list(cells.values()))

    def frame(self) -> pandas.DataFrame:
        return self.db.execute(f"SELECT * FROM {TABLE} ORDER BY scenario, controller, key").df()


def open_store(folder: Path, read_only: bool = False) -> ResultStore:
    """The store of the campaign folder `folder`; raises StoreError."""
    path = folder / STORE_FILE
    if read_only and not path.is_file():
        raise StoreError(f"no store at {path}: run the campaign first")
    return ResultStore(path, read_only)
