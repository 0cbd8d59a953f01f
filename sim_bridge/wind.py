"""The simulated wind (docs/plant-link.md, "Wind"): a mean wind and Dryden turbulence, in the plant's step.

Turbulence is the Dryden model of MIL-HDBK-1797 (MIL-F-8785C) at low altitude, in its discrete form (as MATLAB's
Dryden Wind Turbulence Model (Discrete) has it): three first-order Gauss-Markov gusts, along the air's motion past
the vehicle (u), across it (v) and vertical (w), each with its standard deviation and its scale length at the
height h above home (in feet, as the handbook gives them, 10 ... 1000 ft):

    L_w = h,   L_u = L_v = h / (0.177 + 0.000823 h)^1.2
    sigma_w = SIM_WIND_TURB,   sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4
    gust_{k+1} = a gust_k + sigma sqrt(1 - a^2) n_k,   a = exp(-V dt / L)

V is the speed of the air past the vehicle (the turbulence is frozen in the air the mean wind carries), at least
1 m/s; n_k standard normal draws from a generator seeded with SIM_WIND_SEED, three per plant step while the
turbulence is on. The same seed, the same flight, the same gusts, bit for bit.
"""

from __future__ import annotations

import numpy as np

from transport.wind import Wind

FEET = 0.3048  # m
HEIGHT_RANGE_FT = (10.0, 1000.0)  # the low-altitude model's
AIR_SPEED_MIN = 1.0  # m/s: a hovering vehicle in still air still sees the gusts go by, slowly


def dryden_scales(height_m: float, sigma_w: float) -> tuple[np.ndarray, np.ndarray]:
    """(L_u, L_v, L_w) in m and (sigma_u, sigma_v, sigma_w) in m/s at `height_m` above home."""
    h = min(max(height_m / FEET, HEIGHT_RANGE_FT[0]), HEIGHT_RANGE_FT[1])
    factor = 0.177 + 0.000823 * h
    horizontal = h / factor**1.2 * FEET
    sigma_horizontal = sigma_w / factor**0.4
    return np.array([horizontal, horizontal, h * FEET]), np.array([sigma_horizontal, sigma_horizontal, sigma_w])


def gust_step(gusts: np.ndarray, noise: np.ndarray, air_speed: float, dt: float, lengths: np.ndarray,
              sigmas: np.ndarray) -> np.ndarray:  # fmt: skip
    """The (u, v, w) gusts one step of `dt` seconds later (exact discretisation of the first-order filters)."""
    a = np.exp(-max(air_speed, AIR_SPEED_MIN) * dt / lengths)
    return a * gusts + sigmas * np.sqrt(1.0 - a * a) * noise


def gusts_to_ned(gusts: np.ndarray, air_motion_ne: np.ndarray) -> np.ndarray:
    """(u, v, w) gusts in NED: u along the horizontal motion of the air past the vehicle (north when it is still),
    v to its right, w down."""
    norm = float(np.hypot(air_motion_ne[0], air_motion_ne[1]))
    along = air_motion_ne / norm if norm > 1e-6 else np.array([1.0, 0.0])
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
        self._random = np.random.default_rng(seed)

    def set(self, wind: Wind) -> None:
        """A wind given by its parameters: the horizontal mean and the turbulence; the vertical mean stays. A new
        seed starts the turbulence again from calm with that seed's draws."""
        north, east = wind.north_east
        self.mean_ned[0:2] = north, east
        self.turbulence = wind.turbulence_mps
        if wind.seed != self.seed:
            self.seed = wind.seed
            self._random = np.random.default_rng(wind.seed)
            self.gusts[:] = 0.0

    def step(self, height_m: float, velocity_ned: np.ndarray, dt: float) -> np.ndarray:
        """The wind (NED, m/s) for the next step of `dt` seconds, for a vehicle at `height_m` above home moving at
        `velocity_ned` (the model's own array without turbulence: read it, do not keep it)."""
        if self.turbulence <= 0.0:
            self.gusts[:] = 0.0
            return self.mean_ned
        air_motion = self.mean_ned - velocity_ned  # the air past the vehicle
        lengths, sigmas = dryden_scales(height_m, self.turbulence)
        self.gusts = gust_step(self.gusts, self._random.standard_normal(3), float(np.linalg.norm(air_motion)), dt,
                               lengths, sigmas)  # fmt: skip
        return self.mean_ned + gusts_to_ned(self.gusts, air_motion[0:2])
