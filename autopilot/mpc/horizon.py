"""The MPC's horizon (docs/design/alternatives.md, the long horizon): how long each stage is, and the velocity set-point laid along it.

Every stage lasts a whole number of fine steps (the controller's 10 ms tick), so the grid's node times are exact
multiples of the tick and the warm start can be moved on by one tick by interpolation (`shift_sources`). The
paper's grid is 25 stages of one tick (0.25 s); the long grid starts with fine stages (the plan flown now and
the servo lead) and continues with coarse ones to see seconds ahead for about the same number of stages.
Over seconds, a set-point that turns must be extrapolated as a turn, not as the straight line its rate gives.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from autopilot.mpc.model import MpcWeights


def _read_only(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


@dataclass(frozen=True)
class StageGrid:
    """Stage lengths in ticks of `tick_s` seconds."""

    ticks: tuple[int, ...]
    tick_s: float = 0.01
    substeps: int = 1  # RK4 steps per stage

    def __post_init__(self) -> None:
        if not self.ticks or min(self.ticks) < 1:
            raise ValueError(f"a stage grid needs at least one stage of at least one tick, got {self.ticks}")
        if self.tick_s <= 0 or self.substeps < 1:
            raise ValueError(f"the tick must be positive and a stage at least one RK4 step: {self}")

    @staticmethod
    def uniform(stages: int, tick_s: float = 0.01) -> StageGrid:
        return StageGrid((1,) * stages, tick_s)

    def but(self, **changes) -> StageGrid:
        return dataclasses.replace(self, **changes)

    @property
    def stages(self) -> int:
        return len(self.ticks)

    @functools.cached_property
    def node_ticks(self) -> np.ndarray:
        """Each node's time in ticks from the plan's start: 0, ..., the horizon (N+1 integers; read-only)."""
        return _read_only(np.concatenate(([0], np.cumsum(self.ticks))))

    @functools.cached_property
    def times_s(self) -> np.ndarray:
        """Each node's time (s) from the plan's start (N+1; read-only). Read at every MPC tick: built once."""
        return _read_only(self.node_ticks * self.tick_s)

    @property
    def lengths_s(self) -> np.ndarray:
        """Each stage's length (s) (N)."""
        return np.array(self.ticks, dtype=float) * self.tick_s

    @property
    def span_s(self) -> float:
        return float(self.times_s[-1])

    def node_at(self, seconds: float) -> int:
        """The node nearest `seconds` from the plan's start."""
        return int(np.argmin(np.abs(self.times_s - seconds)))

    def shift_sources(self) -> tuple[np.ndarray, np.ndarray]:
        """Where each node of the plan one tick later lies on the current plan: interval j and the fraction of it
        (0 at node j). Node k of the next plan is at tick node_ticks[k] + 1 of this one; the last node is one
        tick beyond the plan's end, interval N with fraction 1 (the model's step from the last node)."""
        nodes = self.node_ticks
        wanted = nodes + 1
        interval = np.minimum(np.searchsorted(nodes, wanted, side="right") - 1, self.stages)
        lengths = np.append(np.array(self.ticks), 1)
        return interval, (wanted - nodes[interval]) / lengths[interval]


@dataclass(frozen=True)
class MpcHorizon:
    """A named horizon of the MPC: its grid and the weights that go with it."""

    name: str
    grid: StageGrid
    weights: MpcWeights = MpcWeights()
    gauss_newton_steps: int = 1  # QPs per controller tick (RtiSolver)
    turning_setpoint: bool = False  # the set-point extrapolated as a steady turn (extrapolate_setpoint)


def extrapolate_setpoint(
    v_sp: np.ndarray, rate: np.ndarray, times_s: np.ndarray, turning: bool
) -> tuple[np.ndarray, np.ndarray]:
    """The velocity set-point (3, T) and its rate (3, T) at `times_s` ahead, from the set-point v_sp now and its
    rate (m/s^2, NED). Straight: v_sp + rate t, the rate held (the paper's horizon). Turning: the horizontal part's
    speed changes at its along-track rate and its course turns at the steady rate the cross-track rate gives
    (a circle flown at constant speed stays on the circle); the vertical part is straight. Without a horizontal
    speed to turn (under 1 m/s) it is straight."""
    straight = v_sp[:, None] + rate[:, None] * times_s[None, :]
    rates = rate[:, None].repeat(times_s.size, axis=1)
    speed = float(np.hypot(v_sp[0], v_sp[1]))
    if not turning or speed < 1.0:
        return straight, rates
    along = v_sp[0:2] / speed
    across = np.array([-along[1], along[0]])
    rate_along, rate_across = float(rate[0:2] @ along), float(rate[0:2] @ across)
    turn_rate = rate_across / speed
    angle = turn_rate * times_s
    speeds = speed + rate_along * times_s
    heading = np.outer(along, np.cos(angle)) + np.outer(across, np.sin(angle))
    normal = np.outer(across, np.cos(angle)) - np.outer(along, np.sin(angle))
    velocities = straight  # both built above for this call: filled in place
    velocities[0:2] = heading * speeds
    rates[0:2] = heading * rate_along + normal * speeds * turn_rate
    return velocities, rates


PAPER = MpcHorizon("paper", StageGrid.uniform(25))
# 10 stages of 10 ms, then 15 of 130 ms: 2.05 s. See docs/design/alternatives.md, the long horizon for the variants measured.
LONG = MpcHorizon("long", StageGrid((1,) * 10 + (13,) * 15), gauss_newton_steps=2, turning_setpoint=True)
HORIZONS = {h.name: h for h in (PAPER, LONG)}
