"""The MPC's solve times as streaming statistics: count, mean and maximum exactly, median and p99 from a DDSketch
(quantiles within SOLVE_TIME_RELATIVE_ACCURACY of the true ones, in a few hundred bins whatever the flight's length),
so a day-long session keeps a fixed amount of memory for them."""

from __future__ import annotations

from ddsketch import DDSketch

SOLVE_TIME_RELATIVE_ACCURACY = 0.01  # a quantile reported as q is within 1 % of the true one


class SolveTimes:
    """Every solve time (s) added, kept as a sketch."""

    def __init__(self) -> None:
        self._sketch = DDSketch(relative_accuracy=SOLVE_TIME_RELATIVE_ACCURACY)
        self.count = 0
        self.max_s = 0.0
        self.last_s = float("nan")

    def add(self, seconds: float) -> None:
        self._sketch.add(seconds)
        self.count += 1
        self.max_s = max(self.max_s, seconds)
        self.last_s = seconds

    def quantile_s(self, q: float) -> float:
        """The q-quantile (0 .. 1) in seconds, within the relative accuracy; NaN before the first solve."""
        value = self._sketch.get_quantile_value(q) if self.count else None
        return float("nan") if value is None else float(value)

    def summary_ms(self) -> dict[str, float | None]:
        """median, p99 and max in milliseconds (None before the first solve), as a flight's summary gives them."""
        if not self.count:
            return {"solve_ms_median": None, "solve_ms_p99": None, "solve_ms_max": None}
        return {"solve_ms_median": self.quantile_s(0.5) * 1e3, "solve_ms_p99": self.quantile_s(0.99) * 1e3,
                "solve_ms_max": self.max_s * 1e3}  # fmt: skip
