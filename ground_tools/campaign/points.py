"""A campaign's flights: the points of its grid (and seeded samples), each with a key that names it.

The key is a hash of what the flight is (scenario, parameters, controller, repetition) and nothing else, so the
same point gives the same key in every run of the campaign: the store keeps one row per key, and a resumed
campaign skips the keys it has.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from dataclasses import dataclass
from typing import Any

import numpy as np

from ground_tools.campaign.spec import CampaignSpec

RANDOM_DIGITS = 6  # random samples are rounded to this many decimals: tidy keys and rows


@dataclass(frozen=True)
class FlightPoint:
    key: str
    scenario: str
    controller: str
    repetition: int
    params: dict[str, Any]  # the scenario's and the plant's parameters, fixed ones included


def point_key(scenario: str, params: dict[str, Any], controller: str, repetition: int) -> str:
    what = {"scenario": scenario, "params": params, "controller": controller, "repetition": repetition}
    return hashlib.sha256(json.dumps(what, sort_keys=True).encode()).hexdigest()[:16]


def _normal(value: Any) -> Any:
    """Whole floats as they are written in TOML either way (100 and 100.0 are the same point)."""
    return float(value) if isinstance(value, int) and not isinstance(value, bool) else value


def samples(spec: CampaignSpec) -> list[dict[str, float]]:
    """The random axes' seeded draws: `spec.samples` of them (one empty draw without random axes)."""
    if not spec.random:
        return [{}]
    rng = np.random.default_rng(spec.seed)
    names = sorted(spec.random)
    draws = rng.uniform(0.0, 1.0, size=(spec.samples, len(names)))
    return [{name: round(spec.random[name].low + (spec.random[name].high - spec.random[name].low) * float(u),
                         RANDOM_DIGITS) for name, u in zip(names, row)} for row in draws]  # fmt: skip


def campaign_points(spec: CampaignSpec) -> list[FlightPoint]:
    """Every flight of the campaign, each point once, in a stable order."""
    points: dict[str, FlightPoint] = {}
    grid_names = list(spec.grid)
    for values in itertools.product(*(spec.grid[name] for name in grid_names)):
        for draw in samples(spec):
            params = {key: _normal(value) for key, value in
                      {**spec.fixed, **dict(zip(grid_names, values)), **draw}.items()}  # fmt: skip
            for controller in spec.controllers:
                for repetition in range(spec.repetitions):
                    key = point_key(spec.scenario, params, controller, repetition)
                    points.setdefault(key, FlightPoint(key, spec.scenario, controller, repetition, params))
    return list(points.values())
