"""The progress bars of the `vtol` commands (tqdm, on stderr), one look for all of them: how far a flight has
come in simulated seconds, or a count that grows (samples recorded)."""

from __future__ import annotations

import sys

from tqdm import tqdm


def sim_time_bar(total_s: float, desc: str, *, disable: bool, position: int = 0) -> tqdm:
    """A bar over a flight's `total_s` simulated seconds (update it with the seconds flown since the last update)."""
    return tqdm(total=round(total_s, 2), desc=desc, unit="sim s", leave=True, disable=True if disable else None,
                file=sys.stderr, position=position,
                bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining}]")  # fmt: skip


def items_bar(total: int, desc: str, unit: str, *, disable: bool) -> tqdm:
    """A bar over `total` items (a mission's), with a postfix for what else there is to say (simulated time)."""
    return tqdm(total=total, desc=desc, unit=unit, leave=True, disable=True if disable else None, file=sys.stderr,
                bar_format="{desc}: {n}/{total} {unit} |{bar}| {postfix} [{elapsed}]")  # fmt: skip


def counter(desc: str, unit: str, *, disable: bool) -> tqdm:
    """A count with no end known in advance (samples recorded until Ctrl-C), with its rate."""
    return tqdm(desc=desc, unit=unit, leave=True, disable=True if disable else None, file=sys.stderr)


def advance_to(bar: tqdm, value: float) -> None:
    """Move `bar` forward to `value` (never back, never past its total)."""
    target = min(value, bar.total) if bar.total is not None else value
    if target > bar.n:
        bar.update(round(target - bar.n, 2))
