"""The campaign file (TOML, docs/campaigns.md): the scenario, its fixed parameters, the axes (grids or seeded
random samples), the controllers and the repetitions, checked into a CampaignSpec."""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from autopilot.storage.parameters import BY_NAME, ParameterRejected, ParameterStore
from ground_tools.metrics import METRIC_KINDS
from scenarios.variants import PARAMETERS, VariantError, checked_values
from transport.plant_parameters import BY_NAME as PLANT_PARAMETERS
from transport.plant_parameters import refusal
from transport.wind import Wind

CONTROLLERS = ("mpc", "pid")
UPDRAFT = "wind_d_mps"  # the mean wind's vertical velocity (down), m/s: the plant's alone, no parameter
WIND_LIMIT = 40.0  # m/s
RENAMED = {"wind_n_mps": "SIH_WIND_N", "wind_e_mps": "SIH_WIND_E"}  # the mean wind is the plant's parameters
PLANT_AIRFRAME = "plant_airframe"  # an airframe file for the plant only: model mismatch
TOP_LEVEL = ("name", "scenario", "controllers", "repetitions", "seed", "samples", "fixed", "axes", "report")
MAX_FLIGHTS = 1_000_000
MAX_GRID_STEPS = 10_000


class CampaignError(ValueError):
    """The campaign file is unreadable or asks for something it cannot have."""


@dataclass(frozen=True)
class RandomAxis:
    """Seeded uniform samples between low and high."""

    low: float
    high: float


@dataclass(frozen=True)
class CampaignSpec:
    name: str
    scenario: str
    controllers: tuple[str, ...]
    repetitions: int
    fixed: dict[str, Any]
    grid: dict[str, tuple[Any, ...]]  # axis -> its values, in the file's order
    random: dict[str, RandomAxis]
    seed: int
    samples: int
    report: dict[str, str] = field(default_factory=dict)  # x, y, error: what the maps show
    folder: Path = Path(".")  # the file's folder: relative airframe paths start there

    @property
    def axes(self) -> tuple[str, ...]:
        return (*self.grid, *self.random)


def _number(where: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise CampaignError(f"{where}: expected a number, not {value!r}")
    return float(value)


def _whole(where: str, value: Any, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise CampaignError(f"{where}: expected a whole number in {low} .. {high}, not {value!r}")
    return value


def _grid_values(name: str, axis: Any) -> tuple[Any, ...] | RandomAxis:
    if isinstance(axis, list):
        if not axis:
            raise CampaignError(f"axes.{name}: an empty list")
        return tuple(axis)
    if isinstance(axis, dict) and set(axis) == {"from", "to", "steps"}:
        start, stop = _number(f"axes.{name}.from", axis["from"]), _number(f"axes.{name}.to", axis["to"])
        steps = _whole(f"axes.{name}.steps", axis["steps"], 1, MAX_GRID_STEPS)
        if steps == 1:
            return (start,)
        return tuple(round(start + (stop - start) * i / (steps - 1), 9) for i in range(steps))
    if isinstance(axis, dict) and set(axis) == {"uniform"}:
        bounds = axis["uniform"]
        if not isinstance(bounds, list) or len(bounds) != 2:
            raise CampaignError(f"axes.{name}.uniform: expected [low, high], not {bounds!r}")
        low, high = (_number(f"axes.{name}.uniform", v) for v in bounds)
        if not low < high:
            raise CampaignError(f"axes.{name}.uniform: low must be below high, got {bounds!r}")
        return RandomAxis(low, high)
    raise CampaignError(f"axes.{name}: expected a list of values, {{from, to, steps}} or {{uniform = [low, high]}}, "
                        f"not {axis!r}")  # fmt: skip


def autopilot_parameters(values: dict[str, Any]) -> dict[str, float]:
    """The values that are the autopilot's parameters (their PX4-style names: VT_MPC_Q_VN, MC_ROLLRATE_P ...)."""
    return {key: value for key, value in values.items() if key in BY_NAME and key not in PLANT_PARAMETERS}


def scenario_parameters(values: dict[str, Any]) -> dict[str, Any]:
    """The values that are the scenario's own (not the plant's nor the autopilot's)."""
    return {key: value for key, value in values.items()
            if key != UPDRAFT and key != PLANT_AIRFRAME and key not in BY_NAME and key not in PLANT_PARAMETERS}  # fmt: skip


def plant_wind(values: dict[str, Any]) -> tuple[tuple[float, float, float], float, int]:
    """The plant's wind of a flight: its mean velocity (NED, m/s: SIH_WIND_N and SIH_WIND_E, where it comes from,
    negated; wind_d_mps), the turbulence (SIM_WIND_TURB) and its seed (SIM_WIND_SEED)."""
    given = Wind(float(values.get("SIH_WIND_N", 0.0)), float(values.get("SIH_WIND_E", 0.0)),
                 float(values.get("SIM_WIND_TURB", 0.0)), int(values.get("SIM_WIND_SEED", 0)))  # fmt: skip
    north, east = given.velocity_ne
    return (north, east, float(values.get(UPDRAFT, 0.0))), given.turbulence, given.seed


def check_parameters(scenario: str, values: dict[str, Any], folder: Path) -> None:
    """Raise CampaignError unless every value is one the scenario, the plant or the autopilot takes, in range."""
    autopilot = autopilot_parameters(values)
    store = ParameterStore(None)
    for key, value in autopilot.items():
        try:
            store.check(key, _number(key, value))
        except ParameterRejected as exc:
            raise CampaignError(str(exc)) from None
    for key in set(values) & set(RENAMED):
        raise CampaignError(f"{key}: the mean wind is {RENAMED[key]}, m/s where the wind comes from (PX4's SIH)")
    for key in set(values) & set(PLANT_PARAMETERS):
        if (why := refusal(PLANT_PARAMETERS[key], _number(key, values[key]))) is not None:
            raise CampaignError(why)
    own = scenario_parameters(values)
    try:
        checked_values(scenario, own)
    except VariantError as exc:
        raise CampaignError(str(exc)) from None
    if UPDRAFT in values and not -WIND_LIMIT <= _number(UPDRAFT, values[UPDRAFT]) <= WIND_LIMIT:
        raise CampaignError(f"{UPDRAFT} = {values[UPDRAFT]!r} is outside -{WIND_LIMIT:g} .. {WIND_LIMIT:g} m/s")
    if PLANT_AIRFRAME in values:
        airframe = values[PLANT_AIRFRAME]
        if not isinstance(airframe, str) or not (folder / airframe).is_file():
            raise CampaignError(f"{PLANT_AIRFRAME} {airframe!r}: no such file (relative to {folder})")


def parse_campaign(data: dict[str, Any], name: str, folder: Path) -> CampaignSpec:
    """A checked CampaignSpec from the file's tables; raises CampaignError."""
    unknown = set(data) - set(TOP_LEVEL)
    if unknown:
        raise CampaignError(f"unknown key(s) {', '.join(sorted(unknown))}: a campaign has {', '.join(TOP_LEVEL)}")
    scenario = data.get("scenario")
    if scenario not in PARAMETERS:
        raise CampaignError(f"scenario: one of {', '.join(PARAMETERS)}, not {scenario!r}")
    controllers = data.get("controllers", list(CONTROLLERS))
    if not isinstance(controllers, list) or not controllers or not set(controllers) <= set(CONTROLLERS) \
            or len(set(controllers)) != len(controllers):  # fmt: skip
        raise CampaignError(f"controllers: a list of distinct ones of {', '.join(CONTROLLERS)}, not {controllers!r}")
    fixed, axes = data.get("fixed", {}), data.get("axes", {})
    if not isinstance(fixed, dict) or not isinstance(axes, dict):
        raise CampaignError("fixed and axes must be tables")
    both = set(fixed) & set(axes)
    if both:
        raise CampaignError(f"{', '.join(sorted(both))}: both fixed and an axis")
    grid: dict[str, tuple[Any, ...]] = {}
    random: dict[str, RandomAxis] = {}
    for axis, values in axes.items():
        parsed = _grid_values(axis, values)
        if isinstance(parsed, RandomAxis):
            random[axis] = parsed
        else:
            grid[axis] = parsed
    check_parameters(scenario, fixed, folder)
    for axis, values in grid.items():
        for value in values:
            check_parameters(scenario, {axis: value}, folder)
    for axis, bounds in random.items():
        check_parameters(scenario, {axis: bounds.low}, folder)
        check_parameters(scenario, {axis: bounds.high}, folder)
    samples = _whole("samples", data.get("samples", 1 if random else 0), 0, MAX_FLIGHTS)
    if random and samples == 0:
        raise CampaignError("samples: random axes need samples >= 1")
    report = data.get("report", {})
    if not isinstance(report, dict) or not set(report) <= {"x", "y", "error"} \
            or not all(isinstance(v, str) for v in report.values()):  # fmt: skip
        raise CampaignError("report: a table with x, y (axes) and error (a metric), as strings")
    for key in ("x", "y"):
        if key in report and report[key] not in (*grid, *random):
            raise CampaignError(f"report.{key} = {report[key]!r} is not an axis")
    if "error" in report and METRIC_KINDS.get(report["error"]) not in (float, int):
        numeric = ", ".join(name for name, kind in METRIC_KINDS.items() if kind in (float, int))
        raise CampaignError(f"report.error = {report['error']!r} is not a metric the error map can show: one of "
                            f"{numeric}")  # fmt: skip
    spec = CampaignSpec(
        name=str(data.get("name", name)), scenario=scenario, controllers=tuple(controllers),
        repetitions=_whole("repetitions", data.get("repetitions", 1), 1, 1000), fixed=dict(fixed), grid=grid,
        random=random, seed=_whole("seed", data.get("seed", 0), 0, 2**32 - 1), samples=samples, report=report,
        folder=folder,
    )  # fmt: skip
    count = flight_count(spec)
    if count > MAX_FLIGHTS:
        raise CampaignError(f"{count} flights: more than {MAX_FLIGHTS}")
    return spec


def flight_count(spec: CampaignSpec) -> int:
    count = len(spec.controllers) * spec.repetitions * (spec.samples if spec.random else 1)
    for values in spec.grid.values():
        count *= len(values)
    return count


def load_campaign(path: Path) -> CampaignSpec:
    """Read and check a campaign file; raises CampaignError."""
    try:
        data = tomllib.loads(path.read_text())
    except OSError as exc:
        raise CampaignError(f"cannot read {path}: {exc.strerror}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise CampaignError(f"{path} is not TOML: {exc}") from None
    return parse_campaign(data, path.stem, path.resolve().parent)
