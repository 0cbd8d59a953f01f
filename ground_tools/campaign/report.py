"""The campaign's Markdown report and its envelope figures, from the store's rows alone (`vtol campaign FILE
--report` rewrites it from a finished store): what was flown, the survival and error maps of each controller with
the paper's statements, where the survivable region begins, and the flights that failed."""

from __future__ import annotations

import datetime
from pathlib import Path

import pandas

from ground_tools.campaign.envelope import MapAxes, flown, lost_at, map_axes, maps, paper_lines, safe_from
from ground_tools.campaign.envelope_figures import NAMES, plot_map
from ground_tools.campaign.spec import CampaignSpec, flight_count

REPORT_FILE = "report.md"
FIGURES = "figures"
FAILED_SHOWN = 20


def _fmt(value: object) -> str:
    if value is None or (isinstance(value, float) and pandas.isna(value)):
        return "–"
    return f"{value:g}" if isinstance(value, (int, float)) else str(value)


def _table(frame: pandas.DataFrame, axes: MapAxes, digits: int) -> list[str]:
    columns = list(frame.columns)
    lines = [f"| {axes.y or ''} \\ {axes.x} | " + " | ".join(_fmt(c) for c in columns) + " |",
             "| --- |" + " --- |" * len(columns)]  # fmt: skip
    for y, row in frame.iterrows():
        cells = ["–" if pandas.isna(row[c]) else f"{row[c]:.{digits}f}" for c in columns]
        lines.append(f"| {_fmt(y)} | " + " | ".join(cells) + " |")
    return lines


def _summary(spec: CampaignSpec, frame: pandas.DataFrame) -> list[str]:
    done = flown(frame)
    failed = frame[frame["status"] != "done"]
    lines = [f"Scenario `{spec.scenario}`; controllers {', '.join(NAMES.get(c, c) for c in spec.controllers)}; axes "
             + (", ".join(f"`{a}`" for a in spec.axes) or "none")
             + (f"; fixed {', '.join(f'`{k}` = {v}' for k, v in spec.fixed.items())}" if spec.fixed else "") + ".", "",
             f"Flights: {flight_count(spec)} planned, {len(frame)} in the store, {len(done)} flown, {len(failed)} "
             f"failed to fly.", ""]  # fmt: skip
    if not done.empty:
        lines += [f"Per flight: {done['sim_s'].mean():.1f} s simulated, {done['wall_s'].mean():.1f} s of wall clock "
                  f"on a worker (median {done['wall_s'].median():.1f} s).",
                  f"Code: {', '.join(sorted(done['code_version'].dropna().unique()))}; hosts: "
                  f"{', '.join(sorted(done['host'].dropna().unique()))}.", ""]  # fmt: skip
        for controller, rows in done.groupby("controller"):
            lines.append(f"- {NAMES.get(str(controller), controller)}: {int(rows['survived'].sum())} of {len(rows)} "
                         f"survived.{_detection(rows)}")  # fmt: skip
        lines.append("")
    return lines


def _detection(rows: pandas.DataFrame) -> str:
    """How soon the autopilot found the injected failures (`detected_after_s`), as a sentence; empty without any."""
    if "detected_after_s" not in rows.columns:  # a store written before the metric was added
        return ""
    injected = rows["failure_t_s"].notna()
    found = rows.loc[injected, "detected_after_s"].dropna() * 1000.0
    if not injected.any():
        return ""
    if found.empty:
        return f" The failure was found in none of {int(injected.sum())} flights."
    return (f" The failure was found in {len(found)} of {int(injected.sum())} flights, {found.median():.0f} ms after "
            f"its injection (median; worst {found.max():.0f} ms).")  # fmt: skip


def _boundaries(spec: CampaignSpec, axes: MapAxes, survival: dict[str, pandas.DataFrame]) -> list[str]:
    lines = ["## Where the survivable region begins", "",
             f"For each {axes.y or 'map'}: the {axes.x} values where a flight was lost, and the smallest {axes.x} from "
             "which every flight survived.", "",
             f"| controller | {axes.y or ''} | lost at {axes.x} | all survived from {axes.x} |",
             "| --- | --- | --- | --- |"]  # fmt: skip
    for controller, frame in survival.items():
        safe, lost = safe_from(frame), lost_at(frame)
        for y in frame.index:
            lines.append(f"| {NAMES.get(controller, controller)} | {_fmt(y)} | "
                         f"{', '.join(_fmt(x) for x in lost[y]) or 'none'} | {_fmt(safe[y])} |")  # fmt: skip
    lines.append("")
    for line in paper_lines(spec):
        if line.axis != axes.x:
            continue
        for controller, frame in survival.items():
            safe = [s for s in safe_from(frame).values()]
            worst = None if any(s is None for s in safe) else max(safe)
            verdict = (f"survives every {axes.x} from {worst:g} on at every {axes.y or 'point'} flown"
                       if worst is not None else f"loses flights even at the largest {axes.x} flown")  # fmt: skip
            lines.append(f"- {line.text.replace(chr(10), ' ')}; {NAMES.get(controller, controller)}: {verdict}.")
        lines.append("")
    return lines


def write_report(spec: CampaignSpec, frame: pandas.DataFrame, out: Path) -> Path:
    """Write `out`/report.md and the figures in `out`/figures/; returns the report's path."""
    figures = out / FIGURES
    figures.mkdir(parents=True, exist_ok=True)
    lines = [
        f"# Campaign {spec.name}",
        "",
        f"Written {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC from the store `campaign.duckdb`.",
        "",
    ]
    lines += _summary(spec, frame)
    axes = map_axes(spec)
    per_controller = maps(frame, axes) if axes is not None else {}
    if axes is not None and per_controller:
        lines_drawn = paper_lines(spec)
        survival = {c: m["survival"] for c, m in per_controller.items()}
        survival_png = plot_map(survival, axes, lines_drawn, f"{spec.name}: fraction of flights survived",
                                "survived (fraction)", figures / "survival.png", 0.0, 1.0)  # fmt: skip
        lines += ["## Survival", "", f"![survival map]({FIGURES}/{survival_png.name})", ""]
        for controller, frame_ in survival.items():
            lines += [f"{NAMES.get(controller, controller)}, fraction survived:", "", *_table(frame_, axes, 2), ""]
        errors = {c: m["error"] for c, m in per_controller.items() if m["error"] is not None}
        if errors:
            error_png = plot_map(errors, axes, lines_drawn, f"{spec.name}: median {axes.error}", axes.error,
                                 figures / "error.png", cmap="viridis", fmt="{:.3g}")  # fmt: skip
            lines += [
                f"## Tracking error (`{axes.error}`, median per cell)",
                "",
                f"![error map]({FIGURES}/{error_png.name})",
                "",
            ]
            for controller, frame_ in errors.items():
                name = NAMES.get(controller, controller)
                lines += [f"{name}, median {axes.error}:", "", *_table(frame_, axes, 3), ""]
        lines += _boundaries(spec, axes, survival)
    failed = frame[frame["status"] != "done"]
    if not failed.empty:
        lines += ["## Flights that failed to fly", ""]
        for _, row in failed.head(FAILED_SHOWN).iterrows():
            reason = str(row["error"]).strip().splitlines()[-1] if row["error"] else "unknown"
            lines.append(f"- `{row['key']}` ({row['controller']}, {row['params']}): {reason}")
        lines.append("")
    path = out / REPORT_FILE
    path.write_text("\n".join(lines))
    return path
