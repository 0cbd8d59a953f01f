"""The envelope maps as PNG figures: survival and tracking error, one panel per controller side by side, each
cell annotated, the paper's statements drawn on them (envelope.py computes what is drawn)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas  # noqa: E402
from matplotlib import patheffects  # noqa: E402

from ground_tools.campaign.envelope import MapAxes, PaperLine  # noqa: E402

NAMES = {"mpc": "MPC", "pid": "PID"}


def _position(values: list, value: float) -> float:
    """Where `value` falls on a categorical axis of sorted numeric `values` (cell centres at 0, 1, ...)."""
    numbers = np.array(values, dtype=float)
    if numbers.size == 1:
        return 0.0 if value <= numbers[0] else 0.5
    return float(np.interp(value, numbers, np.arange(numbers.size), left=-0.5, right=numbers.size - 0.5))


def _draw_paper(ax: plt.Axes, lines: list[PaperLine], axes: MapAxes, xs: list, ys: list) -> None:
    for line in lines:
        on_x = line.axis == axes.x
        if not on_x and line.axis != axes.y:
            continue
        values = xs if on_x else ys
        try:
            end = _position(values, line.value)
        except (TypeError, ValueError):
            continue
        span = ax.axvspan if on_x else ax.axhspan
        rule = ax.axvline if on_x else ax.axhline
        if line.band_from is None:
            rule(end, color="black", linewidth=2.5, linestyle="--")
        else:
            span(_position(values, line.band_from), end, facecolor="none", edgecolor="black", hatch="//", linewidth=0)
            rule(end, color="black", linewidth=1.5, linestyle="--")


def plot_map(
    per_controller: dict[str, pandas.DataFrame],
    axes: MapAxes,
    lines: list[PaperLine],
    title: str,
    colorbar: str,
    path: Path,
    vmin: float | None = None,
    vmax: float | None = None,
    cmap: str = "RdYlGn",
    fmt: str = "{:.2f}",
) -> Path:
    """One map per controller, side by side on a shared colour scale; NaN cells left blank."""
    controllers = sorted(per_controller)
    xs = sorted(set().union(*(frame.columns for frame in per_controller.values())))
    ys = sorted(set().union(*(frame.index for frame in per_controller.values())))
    values = {c: per_controller[c].reindex(index=ys, columns=xs).to_numpy(dtype=float) for c in controllers}
    finite = np.concatenate([v[np.isfinite(v)] for v in values.values()]) if values else np.array([])
    low = vmin if vmin is not None else (float(finite.min()) if finite.size else 0.0)
    high = vmax if vmax is not None else (float(finite.max()) if finite.size else 1.0)
    fig, panels = plt.subplots(
        1,
        len(controllers),
        figsize=(1.2 + 0.9 * len(xs) * len(controllers) + 1.5, 1.6 + 0.55 * len(ys)),
        squeeze=False,
        sharey=True,
    )
    image = None
    for ax, controller in zip(panels[0], controllers):
        grid = values[controller]
        image = ax.imshow(grid, origin="lower", aspect="auto", cmap=cmap, vmin=low, vmax=max(high, low + 1e-9))
        for (row, column), value in np.ndenumerate(grid):
            if np.isfinite(value):
                ax.text(
                    column,
                    row,
                    fmt.format(value),
                    ha="center",
                    va="center",
                    fontsize=7,
                    path_effects=[patheffects.withStroke(linewidth=2.5, foreground="white")],
                )
        ax.set_xticks(range(len(xs)), [f"{x:g}" if isinstance(x, (int, float)) else str(x) for x in xs], fontsize=7)
        ax.set_yticks(range(len(ys)), [f"{y:g}" if isinstance(y, (int, float)) else str(y) for y in ys], fontsize=7)
        ax.set_xlabel(axes.x)
        ax.set_title(NAMES.get(controller, controller))
        _draw_paper(ax, lines, axes, xs, ys)
    panels[0][0].set_ylabel(axes.y or "")
    fig.suptitle(title, fontsize=10, y=1.02)
    drawn = [line for line in lines if line.axis in (axes.x, axes.y)]
    if drawn:
        caption = "; ".join(("hatched: " if line.band_from is not None else "dashed: ") + line.text.replace("\n", " ")
                            for line in drawn)  # fmt: skip
        fig.text(0.01, -0.04, caption, fontsize=8, ha="left", va="top")
    if image is not None:
        fig.colorbar(image, ax=panels[0].tolist(), label=colorbar, shrink=0.9)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path
