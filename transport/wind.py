"""The simulated wind as its users give it: a mean wind by its speed and the direction it blows from, Dryden
turbulence by its intensity, and the turbulence's seed (docs/plant-link.md, "Wind")."""

from __future__ import annotations

import math
from dataclasses import dataclass

from transport.plant_parameters import BY_NAME, refusal


@dataclass(frozen=True)
class Wind:
    speed_mps: float = 0.0  # the mean wind's horizontal speed
    from_deg: float = 0.0  # where it blows from: 0 north, 90 east (a wind "from the west" is 270)
    turbulence_mps: float = 0.0  # the vertical gusts' standard deviation (0: none)
    seed: int = 0

    def check(self) -> None:
        """ValueError naming the first value out of its parameter's range."""
        for name, value in (("SIM_WIND_SPD", self.speed_mps), ("SIM_WIND_DIR", self.from_deg),
                            ("SIM_WIND_TURB", self.turbulence_mps), ("SIM_WIND_SEED", self.seed)):  # fmt: skip
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"wind: {name} must be a number, not {value!r}")
            if (why := refusal(BY_NAME[name], float(value))) is not None:
                raise ValueError(f"wind: {why}")

    @property
    def north_east(self) -> tuple[float, float]:
        """The mean wind's velocity north and east (m/s): it blows towards from_deg + 180."""
        towards = math.radians(self.from_deg) + math.pi
        return self.speed_mps * math.cos(towards), self.speed_mps * math.sin(towards)


def speed_and_direction(north: float, east: float) -> tuple[float, float]:
    """A horizontal wind velocity (m/s) as its speed and the direction it blows from (deg, 0 .. 360)."""
    speed = math.hypot(north, east)
    return speed, (math.degrees(math.atan2(-east, -north)) % 360.0 if speed > 0 else 0.0)
