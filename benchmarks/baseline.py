"""The benchmarks' `--baseline DIR`: a command run with another checkout's code, and this tree's figures against
the checkout's, round by round (the machine's noise meets both alike)."""

from __future__ import annotations

import os
import statistics
import subprocess
from pathlib import Path
from typing import Any


def run_in(command: list[str], tree: Path | None, **options: Any) -> subprocess.CompletedProcess[str]:
    """`command` with this tree's code (`tree` None), or with the checkout `tree`'s: its folder on PYTHONPATH and
    as the working directory (`python -m` looks in the working directory first)."""
    if tree is None:
        return subprocess.run(command, text=True, **options)
    tree = tree.resolve()
    return subprocess.run(command, text=True, env={**os.environ, "PYTHONPATH": str(tree)}, cwd=tree, **options)


def ratio_summary(label: str, here: list[float], there: list[float], better: str) -> str:
    """Both trees' medians and this tree's ratio to the baseline's, round by round."""
    ratios = [a / b for a, b in zip(here, there)]
    return (f"{label}: this tree median {statistics.median(here):.2f}, baseline {statistics.median(there):.2f}; "
            f"this / baseline, round by round: median {statistics.median(ratios):.3f} (min {min(ratios):.3f}, "
            f"max {max(ratios):.3f}; {better} is better)")  # fmt: skip
