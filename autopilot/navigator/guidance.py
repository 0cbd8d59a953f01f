"""Guidance maths for the automatic modes: positions to velocity set-points (NED, m/s). Pure functions, no state.

leg_velocity      along a straight leg at the cruise speed, converging to the line (cross-track term) and
                  braking into its end with the stopping-distance law sqrt(2 a d) (P near it)
circle_velocity   a vector field onto a circle (the fixed-wing Hold and Orbit)
vertical_velocity P on the altitude error, bounded by the climb and descent limits
ramp              a set-point changed by at most `accel` per second (the velocity controller gets a ramp)
turn_ramp         in forward flight: the speed ramped, its direction not (the course loop turns)
leg_cruise_speed  the speed a leg is flown at: the mission's own (DO_CHANGE_SPEED); else, after a
                  DO_VTOL_TRANSITION item, the cruise speed of the phase it asked for; else the forward-flight
                  cruise speed when the leg is long enough to reach it and stop again, the multicopter one otherwise
"""

from __future__ import annotations

import math

import numpy as np

TICK_S = 0.01  # the navigator and the commander run at the velocity controller's 100 Hz
ORIGIN_NED = np.zeros(3)  # the local frame's origin (read-only)
ORIGIN_NED.flags.writeable = False
CROSS_TRACK_LIMIT = 0.5  # fraction of the leg speed the cross-track correction may add (at most)


def limit_norm(vector: np.ndarray, limit: float) -> np.ndarray:
    norm = float(np.hypot(vector[0], vector[1]))
    return vector * (limit / norm) if norm > limit else vector


def stopping_speed(distance: float, accel: float, gain: float) -> float:
    """The fastest speed that still stops in `distance` at `accel` (P with `gain` close in)."""
    return min(math.sqrt(2.0 * accel * max(distance, 0.0)), gain * max(distance, 0.0))


def leg_velocity(position: np.ndarray, start: np.ndarray, end: np.ndarray, speed: float, accel: float,
                 gain: float, brake: bool = True) -> np.ndarray:  # fmt: skip
    """Horizontal velocity (2) flying the leg start -> end (2-vectors): along it at `speed`, braking into `end`
    (brake False: through it at `speed`, as a fixed wing flies a waypoint), and back to the line at `gain` times
    the cross-track error (at most CROSS_TRACK_LIMIT of `speed`)."""
    leg = end - start
    length = float(np.hypot(*leg))
    to_end = end - position
    if length < 1e-6:
        distance = float(np.hypot(*to_end))
        if distance < 1e-6:
            return np.zeros(2)
        return to_end / distance * min(speed, stopping_speed(distance, accel, gain))
    along_unit = leg / length
    normal = np.array([-along_unit[1], along_unit[0]])
    to_go = float(to_end @ along_unit)
    cross = float((position - start) @ normal)
    if to_go > 0:
        along = min(speed, stopping_speed(to_go, accel, gain)) if brake else speed
    else:
        along = -stopping_speed(-to_go, accel, gain)
    correction = -gain * cross
    limit = CROSS_TRACK_LIMIT * max(speed, 1.0)
    correction = min(max(correction, -limit), limit)
    return along * along_unit + correction * normal


def circle_velocity(position: np.ndarray, center: np.ndarray, radius: float, speed: float, clockwise: bool,
                    convergence: float) -> np.ndarray:  # fmt: skip
    """Horizontal velocity (2) onto the circle: tangential at `speed`, turned towards the circle by 45 deg at
    `convergence` metres off it."""
    offset = position - center
    distance = float(np.hypot(*offset))
    outward = offset / distance if distance >= 1.0 else np.array([1.0, 0.0])
    tangent = np.array([-outward[1], outward[0]]) if clockwise else np.array([outward[1], -outward[0]])
    angle = math.atan((distance - radius) / convergence)
    return speed * (math.cos(angle) * tangent - math.sin(angle) * outward)


def vertical_velocity(down: float, target_down: float, gain: float, up_limit: float, down_limit: float) -> float:
    return min(max(gain * (target_down - down), -up_limit), down_limit)


def ramp(previous: np.ndarray, wanted: np.ndarray, accel: float, dt: float) -> np.ndarray:
    step = wanted - previous
    limit = accel * dt
    norm = float(np.linalg.norm(step))
    return previous + (step * (limit / norm) if norm > limit else step)


def turn_ramp(previous: np.ndarray, wanted: np.ndarray, accel: float, dt: float) -> np.ndarray:
    """In forward flight: the horizontal speed ramped at `accel`, its direction the wanted one at once (the
    fixed-wing course loop turns as fast as its bank limit allows, instead of cutting the corner through slower
    speeds); the vertical ramped as `ramp` does."""
    wanted_speed = float(np.hypot(wanted[0], wanted[1]))
    if wanted_speed < 1e-6:
        return ramp(previous, wanted, accel, dt)
    speed = float(np.hypot(previous[0], previous[1]))
    speed += min(max(wanted_speed - speed, -accel * dt), accel * dt)
    vertical = ramp(previous[2:3], wanted[2:3], accel, dt)
    return np.array([*(wanted[0:2] * (speed / wanted_speed)), vertical[0]])


def leg_cruise_speed(length: float, mission_speed: float | None, mc_cruise: float, fw_cruise: float,
                     accel: float, forward_flight: bool | None = None) -> float:  # fmt: skip
    """`mission_speed` (DO_CHANGE_SPEED) when set; else the phase a DO_VTOL_TRANSITION asked for
    (`forward_flight` True: `fw_cruise`, False: `mc_cruise`); with no such item (None), `fw_cruise` when the leg
    is long enough to accelerate to it and brake from it at `accel` (the unified MPC transitions by itself),
    `mc_cruise` otherwise."""
    if mission_speed is not None:
        return mission_speed
    if forward_flight is not None:
        return fw_cruise if forward_flight else mc_cruise
    return fw_cruise if length >= fw_cruise**2 / accel else mc_cruise
