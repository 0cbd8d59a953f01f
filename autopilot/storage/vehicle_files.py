"""The vehicle's files as PX4 lays out its SD card (/fs/microsd): a root folder that MAVLink FTP serves, with the
ULogs in log/YYYY-MM-DD/HH_MM_SS.ulg (PX4's logger's names, one folder a day), the component metadata in
etc/extras/ (PX4 keeps it there, in ROM), and, for a vehicle that has a folder of its own, its parameter and
mission files.

    <root>/log/2026-05-04/10_31_02.ulg     a flight (LOG_REQUEST_LIST lists these, oldest first)
    <root>/etc/extras/parameters.json       the parameter metadata (COMPONENT_METADATA)

By default the root is microsd-I beside the parameter file (one a vehicle instance); `--root DIR` chooses another,
`--log-dir DIR` puts the logs elsewhere (FTP's /log/ then shows that folder).
"""

from __future__ import annotations

import datetime as dt
import os
from dataclasses import dataclass
from pathlib import Path

LOG_FOLDER = "log"
LOG_SUFFIX = ".ulg"
EXTRAS_FOLDER = Path("etc") / "extras"


def default_root(parameter_path: Path, instance: int) -> Path:
    """microsd-<instance> beside the parameter file."""
    return parameter_path.parent / f"microsd-{instance}"


def log_relative_path(utc: dt.datetime) -> Path:
    """log/YYYY-MM-DD/HH_MM_SS.ulg, as PX4's logger names a log by its start time."""
    return Path(LOG_FOLDER) / utc.strftime("%Y-%m-%d") / (utc.strftime("%H_%M_%S") + LOG_SUFFIX)


@dataclass(frozen=True)
class LogEntry:
    """One ULog on the vehicle: its path, size (bytes) and modification time (UTC seconds)."""

    path: Path
    size: int
    time_utc: int


@dataclass(frozen=True)
class VehicleFiles:
    """The vehicle's root and where its logs go (by default <root>/log)."""

    root: Path
    log_dir: Path

    @classmethod
    def at(cls, root: Path, log_dir: Path | None = None) -> VehicleFiles:
        root = root.absolute()
        return cls(root, (log_dir.absolute() if log_dir is not None else root / LOG_FOLDER))

    @property
    def extras(self) -> Path:
        return self.root / EXTRAS_FOLDER

    def new_log_path(self, utc: dt.datetime) -> Path:
        """Where a log started at `utc` goes: log/YYYY-MM-DD/HH_MM_SS.ulg, with _1, _2... when that name is taken
        (two logs within one second)."""
        relative = log_relative_path(utc).relative_to(LOG_FOLDER)
        path = self.log_dir / relative
        count = 0
        while path.exists():
            count += 1
            path = self.log_dir / relative.parent / f"{relative.stem}_{count}{LOG_SUFFIX}"
        return path

    def logs(self) -> list[LogEntry]:
        """The ULogs in the day folders of the log folder, oldest first (by name: date, then time)."""
        entries = []
        try:
            days = [day for day in os.scandir(self.log_dir) if day.is_dir(follow_symlinks=False)]
        except OSError:
            return []
        for day in sorted(days, key=lambda entry: entry.name):
            try:
                files = [f for f in os.scandir(day.path) if f.is_file(follow_symlinks=False)]
            except OSError:
                continue
            for file in sorted(files, key=lambda entry: entry.name):
                if not file.name.endswith(LOG_SUFFIX):
                    continue
                try:
                    stat = file.stat(follow_symlinks=False)
                except OSError:
                    continue
                entries.append(LogEntry(Path(file.path), stat.st_size, int(stat.st_mtime)))
        return entries
