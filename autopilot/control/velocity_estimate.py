"""The velocity the controllers fly on: the measured velocity, with its quantisation filtered out.

HIL_STATE_QUATERNION carries the velocity in whole cm/s; the MPC answered that +-5 mm/s quantisation with white
noise on its attitude and force set-points (0.1 deg, 0.5 N per 10 ms tick), which the attitude loop
(K_p K_att I ~ 100 N m/rad) and the allocation (roll authority ~3 N m per unit command in cruise) turned into
actuator chatter (docs/autopilot.md). An accelerometer-aided complementary filter, as PX4's estimator blends
the IMU into velocity, removes it without lag.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.topics.vehicle_state import VehicleState

VELOCITY_FILTER_TAU_S = 0.1
VELOCITY_FILTER_GATE = 1.0  # m/s: an estimate further than this from the measurement restarts from it
VELOCITY_FILTER_MAX_GAP_S = 0.05  # a longer gap between states (or the clock going back) restarts it too


class VelocityEstimate:
    """Accelerometer-aided complementary filter on the measured NED velocity, updated at every plant step.

        a  = R_IB f_B + g e_z                              (f_B: the accelerometer's specific force)
        v <- v + (a_prev + a) dt / 2                       (trapezoidal propagation)
        v <- v + dt / (tau + dt) (v_measured - v)          (correction, tau = 0.1 s)

    The acceleration is the plant's own, so the estimate does not lag the measurement in ramps and turns; what
    it removes is the measurement's quantisation and noise above about 1 / (2 pi tau) = 1.6 Hz. Without an
    accelerometer reading (specific force all zero or not finite), after a gap or when it strays more than
    VELOCITY_FILTER_GATE from the measurement, the estimate is the measurement.
    """

    def __init__(self, gravity: float, tau_s: float = VELOCITY_FILTER_TAU_S) -> None:
        self.gravity = gravity
        self.tau_s = tau_s
        self.velocity = np.zeros(3)
        self._estimate: list[float] = [0.0, 0.0, 0.0]
        self._acceleration: tuple[float, float, float] | None = None  # of the previous step
        self._time_usec: int | None = None

    def update(self, state: VehicleState) -> np.ndarray:
        """The estimate at state.time_usec (the array is this object's; copy it to keep it).

        Plain floats on purpose: it runs at every 400 Hz step (~3 us; with numpy 3-vectors it was 14 us)."""
        measured = state.velocity_ned.tolist()
        fx, fy, fz = state.specific_force.tolist()
        acceleration = None
        if (fx != 0.0 or fy != 0.0 or fz != 0.0) and math.isfinite(fx + fy + fz):
            w, x, y, z = state.quaternion.tolist()  # R_IB f = f + 2 w (q x f) + 2 q x (q x f), q = (x, y, z)
            cx, cy, cz = y * fz - z * fy, z * fx - x * fz, x * fy - y * fx
            acceleration = (
                fx + 2.0 * (w * cx + y * cz - z * cy),
                fy + 2.0 * (w * cy + z * cx - x * cz),
                fz + 2.0 * (w * cz + x * cy - y * cx) + self.gravity,
            )
        dt = -1.0 if self._time_usec is None else (state.time_usec - self._time_usec) * 1e-6
        estimate = self._estimate
        if acceleration is None or self._acceleration is None or not 0.0 < dt <= VELOCITY_FILTER_MAX_GAP_S:
            estimate[:] = measured
        else:
            gain = dt / (self.tau_s + dt)
            for i in range(3):
                predicted = estimate[i] + 0.5 * dt * (self._acceleration[i] + acceleration[i])
                estimate[i] = predicted + gain * (measured[i] - predicted)
                if not abs(estimate[i] - measured[i]) <= VELOCITY_FILTER_GATE:  # also catches NaN
                    estimate[:] = measured
                    break
        self.velocity[:] = estimate
        self._acceleration = acceleration
        self._time_usec = state.time_usec
        return self.velocity
