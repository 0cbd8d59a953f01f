"""The simulated wind as its users give it: the mean wind in PX4's SIH convention (SIH_WIND_N, SIH_WIND_E: the
speed it comes from the north and from the east), Dryden turbulence by its intensity (SIM_WIND_TURB), and the
turbulence's seed (SIM_WIND_SEED) (docs/plant-link.md, "Wind")."""

from __future__ import annotations

from dataclasses import dataclass

from transport.plant_parameters import BY_NAME, refusal


@dataclass(frozen=True)
class Wind:
    """from_north, from_east: m/s the mean wind comes from the north and from the east (Wind(from_north=5) blows
    south at 5 m/s); turbulence: m/s, the vertical gusts' standard deviation (0: none); seed: the gusts' seed."""

    from_north: float = 0.0
    from_east: float = 0.0
    turbulence: float = 0.0
    seed: int = 0

    def check(self) -> None:
        """ValueError naming the first value out of its parameter's range."""
        for name, value in self.parameters().items():
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"wind: {name} must be a number, not {value!r}")
            if (why := refusal(BY_NAME[name], float(value))) is not None:
                raise ValueError(f"wind: {why}")

    def parameters(self) -> dict[str, float]:
        """The wind as the plant's parameters, by name."""
        return {"SIH_WIND_N": self.from_north, "SIH_WIND_E": self.from_east, "SIM_WIND_TURB": self.turbulence,
                "SIM_WIND_SEED": self.seed}  # fmt: skip

    @property
    def velocity_ne(self) -> tuple[float, float]:
        """The mean wind's velocity north and east (m/s), the way the air moves."""
        return -self.from_north, -self.from_east


def from_velocity(north: float, east: float, turbulence: float = 0.0, seed: int = 0) -> Wind:
    """The Wind whose air moves at (north, east) m/s."""
    return Wind(-north, -east, turbulence, seed)
