"""The tilt servo check: a tilt servo that does not follow its command, found from the moment it leaves unexplained.

Tilt servos report no position (hobby PWM servos; PX4 has no servo check). What a jam leaves is a moment: rotor i
at tilt chi gives T_i (A_i sin chi + B_i cos chi) (aircraft/rotors.py: its thrust's moment about the centre of
mass and its reaction torque), so a tilt other than the estimated one shows as a moment the model does not
explain. At each ESC report (100 Hz) the check compares

    measured moment  J (omega_k - omega_{k-1}) / dt + omega x J omega     (the mean over the 10 ms since the last)
    modelled moment  the rotors (thrust from their RPM) at the estimated tilts, the wing's damping, the surfaces
                     (the mean of the last two reports')

and, when their difference is at least VT_FD_SRV_MOM, asks for each servo which tilt of that servo alone would
explain it: the least-squares (a, b) of T_i (A_i a + B_i b) = the moment rotor i must be giving, chi = atan2(a, b).
The servo whose tilt explains the difference best (at most a quarter of it left, and at most half of what the
second best leaves), at least VT_FD_SRV_ANG from its estimate, is failing; failing for VT_FD_SRV_TOUT is a jam at
that tilt. A servo that keeps moving after the jam (towards the angle it jammed at) is found again at its new tilt:
a servo found jammed stays among the judged ones however slowly its rotor turns, since the moment it leaves as it
moves on is one a servo on the same side explains almost as well, and that servo would be found jammed instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from aircraft.aerodynamics import surface_moment, wing_wrench
from aircraft.airframe import Airframe
from aircraft.codegen import BufferedFunction
from aircraft.rotors import rotor_wrench

UNEXPLAINED_LEFT_MAX = 0.25  # the best servo's tilt leaves at most this fraction of the unexplained moment
SECOND_BEST_RATIO = 2.0  # ... and the second best servo leaves at least this many times what the best leaves
THRUST_RATIO_TOLERANCE = (
    0.3  # a fit that needs the rotor's thrust changed by more says the thrust is wrong, not the tilt
)
MAX_REPORT_GAP_USEC = 50_000  # reports further apart are not differenced (a pause, a plant restart)


@dataclass(frozen=True)
class ServoCheck:
    """The check's parameters (autopilot/storage/parameters.py)."""

    min_moment: float  # VT_FD_SRV_MOM (N m): an unexplained moment from which the servos are examined
    min_angle_rad: float  # VT_FD_SRV_ANG (deg there): a tilt this far from its estimate is failing
    timeout_usec: int  # VT_FD_SRV_TOUT (ms there): failing this long is a jam


@dataclass(frozen=True)
class TiltFit:
    """The tilt of one servo that best explains a moment, and the moment it leaves unexplained (N m)."""

    servo: int  # 0-based
    tilt_rad: float
    left: float
    thrust_ratio: float  # the fit's thrust over the rotor's (a tilt explains the moment only near 1)


@dataclass(frozen=True)
class ServoJam:
    """A servo found jammed, at the tilt found (rad)."""

    servo: int  # 0-based
    tilt_rad: float
    first: bool  # the first time this servo is found jammed (this flight)


class MomentModel:
    """The body moment the autopilot's model of the aircraft gives, and each rotor's tilt columns A_i, B_i."""

    def __init__(self, airframe: Airframe) -> None:
        self.airframe = airframe
        thrusts, tilts, deflections = ca.SX.sym("T", 4), ca.SX.sym("chi", 4), ca.SX.sym("d", 4)
        airspeed, rates = ca.SX.sym("V"), ca.SX.sym("w", 3)
        _, m_rotor = rotor_wrench(airframe, thrusts, tilts)
        v_air = ca.vertcat(airspeed, 0, 0)  # the wing's damping and the surfaces depend on the airspeed alone
        m_aero = wing_wrench(airframe, v_air, rates)[1] + surface_moment(airframe, v_air, deflections)
        inputs = ca.vertcat(thrusts, tilts, deflections, airspeed, rates)
        self._moment = BufferedFunction(ca.Function("modelled_moment", [inputs], [m_rotor + m_aero]))
        rotor = ca.Function("rotor_moment", [thrusts, tilts], [m_rotor])
        unit = np.eye(4)  # rotor i alone at unit thrust: tilt 90 deg gives A_i, tilt 0 gives B_i
        self.a = [rotor(unit[i], np.full(4, math.pi / 2)).full().ravel().tolist() for i in range(4)]
        self.b = [rotor(unit[i], np.zeros(4)).full().ravel().tolist() for i in range(4)]
        self.inertia = list(airframe.inertia_diag)

    def moment(self, thrusts: list[float], tilts: list[float], deflections: list[float], airspeed: float,
               rates: list[float]) -> list[float]:  # fmt: skip
        """Rotors at `tilts` (rad) with `thrusts` (N), the wing's damping and the surfaces (-1..1): N m, body."""
        return self._moment([*thrusts, *tilts, *deflections, airspeed, *rates])[0].tolist()

    def rotor(self, servo: int, thrust: float, tilt: float) -> list[float]:
        """Rotor `servo`'s own moment at `thrust` (N) and `tilt` (rad)."""
        s, c = thrust * math.sin(tilt), thrust * math.cos(tilt)
        return [s * a + c * b for a, b in zip(self.a[servo], self.b[servo])]

    def tilt_sensitivity(self, servo: int, thrust: float, tilt: float) -> float:
        """|d M_i / d chi| (N m per rad): how much rotor `servo`'s moment changes with its tilt."""
        s, c = thrust * math.cos(tilt), -thrust * math.sin(tilt)
        return math.sqrt(sum((s * a + c * b) ** 2 for a, b in zip(self.a[servo], self.b[servo])))

    def gyroscopic(self, rates: list[float], angular_acceleration: list[float]) -> list[float]:
        """J omega_dot + omega x J omega: the moment that turns the body as measured (N m)."""
        (jx, jy, jz), (p, q, r) = self.inertia, rates
        hx, hy, hz = jx * p, jy * q, jz * r
        ax, ay, az = angular_acceleration
        return [jx * ax + q * hz - r * hy, jy * ay + r * hx - p * hz, jz * az + p * hy - q * hx]


def _dot(u: list[float], v: list[float]) -> float:
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def fit_tilt(model: MomentModel, servo: int, required: list[float], thrust: float) -> TiltFit:
    """The tilt of `servo` (within the servo's range) whose rotor moment is closest to `required` (N m): the
    least-squares (a, b) of thrust (A a + B b) = required, by its normal equations."""
    a_col, b_col = [thrust * x for x in model.a[servo]], [thrust * x for x in model.b[servo]]
    aa, ab, bb = _dot(a_col, a_col), _dot(a_col, b_col), _dot(b_col, b_col)
    ar, br = _dot(a_col, required), _dot(b_col, required)
    determinant = aa * bb - ab * ab
    if not determinant > 0.0:
        return TiltFit(servo, math.nan, math.inf, math.nan)
    a, b = (bb * ar - ab * br) / determinant, (aa * br - ab * ar) / determinant
    airframe = model.airframe
    tilt = min(max(math.atan2(a, b), airframe.tilt_min), airframe.tilt_max)
    left = [x - y for x, y in zip(required, model.rotor(servo, thrust, tilt))]
    return TiltFit(servo, tilt, math.sqrt(_dot(left, left)), math.hypot(a, b))


def best_fits(model: MomentModel, unexplained: list[float], thrusts: list[float], tilts: list[float],
              candidates: list[int]) -> list[TiltFit]:  # fmt: skip
    """Each candidate servo's fit to `unexplained` (measured - modelled, N m), best first."""
    fits = []
    for servo in candidates:
        own = model.rotor(servo, thrusts[servo], tilts[servo])
        fits.append(fit_tilt(model, servo, [x + y for x, y in zip(unexplained, own)], thrusts[servo]))
    return sorted(fits, key=lambda fit: fit.left)


def observable(model: MomentModel, candidates: list[int], thrusts: list[float], tilts: list[float],
               check: ServoCheck) -> list[int]:  # fmt: skip
    """The candidates whose rotor turns hard enough that a tilt VT_FD_SRV_ANG off moves its moment by VT_FD_SRV_MOM:
    a rotor near idle says too little about its tilt to be judged."""
    return [servo for servo in candidates
            if model.tilt_sensitivity(servo, thrusts[servo], tilts[servo]) * check.min_angle_rad >= check.min_moment]  # fmt: skip


def failing_servo(
    fits: list[TiltFit], unexplained_norm: float, tilts: list[float], check: ServoCheck
) -> TiltFit | None:
    """The servo these fits single out, if one explains the moment well, better than the others, at a tilt
    away from its estimate."""
    if unexplained_norm < check.min_moment or not fits:
        return None
    best = fits[0]
    if (
        not best.left <= UNEXPLAINED_LEFT_MAX * unexplained_norm
        or abs(best.thrust_ratio - 1.0) > THRUST_RATIO_TOLERANCE
    ):
        return None
    if len(fits) > 1 and fits[1].left < SECOND_BEST_RATIO * best.left:
        return None
    if abs(best.tilt_rad - tilts[best.servo]) < check.min_angle_rad:
        return None
    return best


@dataclass
class ServoJamDetector:
    """The check's memory: the previous report's rates and modelled moment, the servo failing and since when."""

    model: MomentModel
    jammed: list[int] = field(default_factory=list)  # servos found jammed, in the order found
    last_unexplained: float = math.nan  # the last check's unexplained moment (N m)
    _previous: tuple[int, list[float], list[float]] | None = None  # time_usec, rates, modelled moment
    _surfaces: list[float] = field(default_factory=list)  # the surfaces' positions (-1..1), first order on commands
    _failing: tuple[int, int] | None = None  # servo, time_usec of its first failing check

    def sample(
        self,
        now_usec: int,
        rates: list[float],
        thrusts: list[float],
        tilts: list[float],
        deflections: list[float],
        airspeed: float,
        candidates: list[int],
        check: ServoCheck,
    ) -> ServoJam | None:
        """One ESC report's check: rotor thrusts (N), estimated tilts (rad), the surfaces' commands (-1..1), the
        true airspeed (m/s), body rates (rad/s); `candidates` the servos that may be judged (their motor not known
        failed). A ServoJam when one has been failing for the timeout."""
        previous, surfaces = self._previous, self._surfaces
        if previous is None or not 0 < now_usec - previous[0] <= MAX_REPORT_GAP_USEC:
            self._surfaces = list(deflections)
            self._previous = (now_usec, list(rates), self.model.moment(thrusts, tilts, deflections, airspeed, rates))
            self._failing = None
            return None
        dt = (now_usec - previous[0]) * 1e-6
        blend = 1.0 - math.exp(-dt / self.model.airframe.surface_tau)  # exact for a command held since the last
        surfaces = [x + (command - x) * blend for x, command in zip(surfaces, deflections)]
        modelled = self.model.moment(thrusts, tilts, surfaces, airspeed, rates)
        last_rates, last_modelled = previous[1], previous[2]
        self._surfaces, self._previous = surfaces, (now_usec, list(rates), modelled)
        mean_rates = [0.5 * (x + y) for x, y in zip(rates, last_rates)]
        measured = self.model.gyroscopic(mean_rates, [(x - y) / dt for x, y in zip(rates, last_rates)])
        unexplained = [m - 0.5 * (x + y) for m, x, y in zip(measured, modelled, last_modelled)]
        norm = math.sqrt(_dot(unexplained, unexplained))
        self.last_unexplained = norm
        fit = None
        if norm >= check.min_moment:
            judged = observable(self.model, candidates, thrusts, tilts, check)
            judged += [servo for servo in self.jammed if servo in candidates and servo not in judged]
            if len(judged) >= 2:  # one alone cannot be told from a moment it happens to fit
                fit = failing_servo(best_fits(self.model, unexplained, thrusts, tilts, judged), norm, tilts, check)
        if fit is None:
            self._failing = None
            return None
        if self._failing is None or self._failing[0] != fit.servo:
            self._failing = (fit.servo, now_usec)
        if now_usec - self._failing[1] < check.timeout_usec:
            return None
        self._failing = None
        first = fit.servo not in self.jammed
        if first:
            self.jammed.append(fit.servo)
        return ServoJam(fit.servo, fit.tilt_rad, first)

    def free(self, servo: int) -> None:
        """Servo `servo` is no longer jammed (it follows its command again)."""
        if servo in self.jammed:
            self.jammed.remove(servo)

    def pause(self) -> None:
        """The check is not running (on the ground, disabled): nothing is failing, no report to difference."""
        self._failing = None
        self._previous = None

    def reset(self) -> None:
        """Disarmed: nothing is jammed or failing."""
        self.jammed.clear()
        self.pause()
