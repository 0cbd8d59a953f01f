"""The simulated wind (docs/plant-link.md, "Wind"): a mean wind and Dryden turbulence, in the plant's step.

Turbulence is the Dryden model of MIL-F-8785C / MIL-HDBK-1797 at low altitude, in its discrete form (as MATLAB's
Dryden Wind Turbulence Model (Discrete) has it): three first-order Gauss-Markov gusts, along the mean wind (u),
across it (v) and vertical (w), each with its standard deviation and scale length at the model's height h (in
feet, as the handbook gives them):

    L_w = h,   L_u = L_v = h / (0.177 + 0.000823 h)^1.2
    sigma_w = SIM_WIND_TURB,   sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4
    gust_{k+1} = a gust_k + sigma sqrt(1 - a^2) n_k,   a = exp(-V dt / L)

The turbulence is the frozen field the mean wind carries past a vehicle holding its place: V is the mean wind's
speed (at least AIR_SPEED_MIN) and h is DRYDEN_HEIGHT_M, not the vehicle's own airspeed and height, so that the
gusts are a function of the seed and the plant's steps alone: two controllers flown with one seed meet the same
gusts, whatever each does. n_k are standard normal draws from a generator seeded with SIM_WIND_SEED, three per
plant step while the turbulence is on.
"""

from __future__ import annotations

import numpy as np

from transport.wind import Wind

FEET = 0.3048  # m
DRYDEN_HEIGHT_M = 30.0  # the low-altitude model's height (about 100 ft): the height these flights hover and cruise
AIR_SPEED_MIN = 1.0  # m/s: in still air the gusts still go by, slowly


def dryden_scales(height_m: float, sigma_w: float) -> tuple[np.ndarray, np.ndarray]:
    """(L_u, L_v, L_w) in m and (sigma_u, sigma_v, sigma_w) in m/s at `height_m`, within the low-altitude
    model's 10 ... 1000 ft."""
    h = min(max(height_m / FEET, 10.0), 1000.0)
    factor = 0.177 + 0.000823 * h
    horizontal = h / factor**1.2 * FEET
    sigma_horizontal = sigma_w / factor**0.4
    return np.array([horizontal, horizontal, h * FEET]), np.array([sigma_horizontal, sigma_horizontal, sigma_w])


def gust_step(gusts: np.ndarray, noise: np.ndarray, air_speed: float, dt: float, lengths: np.ndarray,
              sigmas: np.ndarray) -> np.ndarray:  # fmt: skip
    """The (u, v, w) gusts one step of `dt` seconds later (exact discretisation of the first-order filters)."""
    a = np.exp(-max(air_speed, AIR_SPEED_MIN) * dt / lengths)
    return a * gusts + sigmas * np.sqrt(1.0 - a * a) * noise


def gusts_to_ned(gusts: np.ndarray, mean_ne: np.ndarray) -> np.ndarray:
    """(u, v, w) gusts in NED: u along the mean wind's horizontal motion (north in still air), v to its right,
    w down."""
    norm = float(np.hypot(mean_ne[0], mean_ne[1]))
    along = mean_ne / norm if norm > 1e-6 else np.array([1.0, 0.0])
    return np.array([gusts[0] * along[0] - gusts[1] * along[1], gusts[0] * along[1] + gusts[1] * along[0], gusts[2]])


class WindModel:
    """The wind in NED at each plant step: the mean (the command line's, changed by the plant's parameters) plus
    the turbulence."""

    def __init__(self, mean_ned: tuple[float, float, float] = (0.0, 0.0, 0.0), turbulence: float = 0.0,
                 seed: int = 0) -> None:  # fmt: skip
        self.mean_ned = np.array(mean_ned, dtype=float)
        self.turbulence = turbulence
        self.seed = seed
        self.gusts = np.zeros(3)
        self.wind_ned = self.mean_ned.copy()
        self._random = np.random.default_rng(seed)

    def set(self, wind: Wind) -> None:
        """A wind given by its parameters: the horizontal mean and the turbulence; the vertical mean stays. A new
        seed starts the turbulence again from calm with that seed's draws."""
        self.mean_ned[0:2] = wind.velocity_ne
        self.turbulence = wind.turbulence
        if wind.seed != self.seed:
            self.seed = wind.seed
            self._random = np.random.default_rng(wind.seed)
            self.gusts[:] = 0.0

    def step(self, dt: float) -> np.ndarray:
        """The wind (NED, m/s) for the next step of `dt` seconds (the model's own array: read it, do not keep it)."""
        if self.turbulence <= 0.0:
            self.gusts[:] = 0.0
            self.wind_ned[:] = self.mean_ned
            return self.wind_ned
        lengths, sigmas = dryden_scales(DRYDEN_HEIGHT_M, self.turbulence)
        speed = float(np.hypot(self.mean_ned[0], self.mean_ned[1]))
        self.gusts = gust_step(self.gusts, self._random.standard_normal(3), speed, dt, lengths, sigmas)
        self.wind_ned[:] = self.mean_ned + gusts_to_ned(self.gusts, self.mean_ned[0:2])
        return self.wind_ned
