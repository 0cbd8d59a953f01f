"""Envelope maps from a campaign's rows: which two axes a map shows, survival fraction and median tracking error
per cell for each controller, where the survivable region begins, and the paper's statement for the scenario.
Pure functions of pandas frames (the figures are envelope_figures.py)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas

from ground_tools.campaign.spec import CampaignSpec

MAX_CELLS = 8  # an axis with more distinct values (random samples) is cut into this many equal bins
ERROR_METRIC = {"motor-failure": "radial_max_m", "circle": "radial_max_m", "servo-failure": "vx_rmse_after_failure"}
DEFAULT_ERROR = "vx_rmse"
LOW_JAM_DEG = 30.0  # where "a low angle" ends on the maps: the paper names no number (docs/campaigns.md)
PAPER_RADIUS_M = 200.0


@dataclass(frozen=True)
class PaperLine:
    """The paper's statement drawn on a map: a line (value) or a band up to a value, across one axis."""

    axis: str
    value: float
    band_from: float | None  # a band from here to `value`, else a line at `value`
    text: str


@dataclass(frozen=True)
class MapAxes:
    x: str
    y: str | None
    error: str


def map_axes(spec: CampaignSpec) -> MapAxes | None:
    """What the campaign's maps show (its [report] table, else its first two axes); None without axes."""
    axes = spec.axes
    if not axes:
        return None
    x = spec.report.get("x", axes[0])
    rest = [axis for axis in axes if axis != x]
    y = spec.report.get("y", rest[0] if rest else None)
    return MapAxes(x, y, spec.report.get("error", ERROR_METRIC.get(spec.scenario, DEFAULT_ERROR)))


def paper_lines(spec: CampaignSpec) -> list[PaperLine]:
    """The paper's closing statements that concern this campaign's scenario and axes."""
    lines = []
    if spec.scenario == "motor-failure" and "radius_m" in spec.axes and spec.fixed.get("rotor", 1) == 1:
        lines.append(PaperLine("radius_m", PAPER_RADIUS_M, None, "paper: rotor 1 dead, no circle below ~200 m"))
    if spec.scenario == "servo-failure" and "jam_deg" in spec.axes:
        lines.append(PaperLine("jam_deg", LOW_JAM_DEG, -7.0, "paper: jammed at a low angle\nin the transition: lost"))
    return lines


def cell_values(values: pandas.Series) -> pandas.Series:
    """The axis value each row's cell is labelled with: the value itself, or its bin's centre when the axis has
    more than MAX_CELLS distinct values."""
    numeric = pandas.to_numeric(values, errors="coerce")
    if values.nunique() <= MAX_CELLS or numeric.isna().any():
        return values
    edges = np.linspace(float(numeric.min()), float(numeric.max()), MAX_CELLS + 1)
    index = np.clip(np.searchsorted(edges, numeric.to_numpy(), side="right") - 1, 0, MAX_CELLS - 1)
    return pandas.Series(np.round((edges[index] + edges[index + 1]) / 2.0, 3), index=values.index)


def flown(frame: pandas.DataFrame) -> pandas.DataFrame:
    """The rows of flights that were flown (status done), survived as a number."""
    done = frame[frame["status"] == "done"].copy()
    done["survived"] = done["survived"].astype(float)
    return done


def maps(frame: pandas.DataFrame, axes: MapAxes) -> dict[str, dict[str, pandas.DataFrame]]:
    """For each controller: "survival" (fraction of the cell's flights that survived), "error" (median of the
    error metric) and "flights" (count), each a frame with y down (one row without y) and x across."""
    done = flown(frame)
    if done.empty:
        return {}
    done["_x"] = cell_values(done[axes.x])
    done["_y"] = cell_values(done[axes.y]) if axes.y else ""
    result = {}
    for controller, rows in done.groupby("controller", sort=True):
        grouped = rows.groupby(["_y", "_x"])
        result[str(controller)] = {
            "survival": grouped["survived"].mean().unstack("_x"),
            "error": grouped[axes.error].median().unstack("_x") if axes.error in rows else None,
            "flights": grouped.size().unstack("_x"),
        }
    return result


def safe_from(survival: pandas.DataFrame) -> dict[object, float | None]:
    """For each row (y): the smallest x from which every cell at and above it survived every flight (None: even
    the largest x lost a flight)."""
    result: dict[object, float | None] = {}
    for y, row in survival.iterrows():
        xs = sorted(x for x in row.index if not pandas.isna(row[x]))
        boundary = None
        for x in reversed(xs):
            if row[x] < 1.0:
                break
            boundary = x
        result[y] = boundary
    return result


def lost_at(survival: pandas.DataFrame) -> dict[object, list]:
    """For each row (y): the x values of its cells where some flight was lost."""
    return {y: [x for x in row.index if not pandas.isna(row[x]) and row[x] < 1.0] for y, row in survival.iterrows()}
