"""Airframe parameters: the numbers of one aircraft, loaded from a TOML file that gives each one's source.

The file format is documented in docs/airframe-format.md. Loading validates everything (presence,
type, shape, finiteness, sign) and raises AirframeError with one line that names the file and the key.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

DEFAULT_AIRFRAME = "chen2024_tiltrotor.toml"


class AirframeError(ValueError):
    """A broken or invalid airframe file."""


@dataclass(frozen=True)
class Airframe:
    """All physical parameters of the vehicle. SI units unless the name says otherwise."""

    name: str
    # mass_properties
    mass: float
    inertia_diag: tuple[float, float, float]
    # environment
    gravity: float
    air_density: float
    # rotors
    rotor_positions: tuple[tuple[float, float, float], ...]
    spin_directions: tuple[float, ...]
    thrust_coefficient: float
    torque_coefficient: float
    rotor_speed_max: float
    motor_tau_up: float
    motor_tau_down: float
    # tilt_servos
    tilt_min_deg: float
    tilt_max_deg: float
    servo_rate_max_deg_s: float
    servo_tau: float
    # wing
    wing_area: float
    wing_span: float
    mean_chord: float
    CL0: float
    CL_alpha: float
    CD0: float
    oswald_efficiency: float
    CY_beta: float
    Cl_p: float
    Cm_q: float
    Cn_r: float
    stall_blend_rate: float
    stall_alpha0: float
    # aero_effectiveness
    eff_v_onset: float
    eff_v_full: float
    eff_width: float
    eff_v_zero: float
    eff_ramp_span: float
    eff_ramp_gain: float
    # control_surfaces
    aileron_area: float
    elevator_area: float
    rudder_area: float
    aileron_effectiveness: float
    elevator_effectiveness: float
    rudder_effectiveness: float
    surface_tau: float
    surface_max_deflection_deg: float
    # landing_gear
    gear_points: tuple[tuple[float, float, float], ...]
    gear_stiffness: float
    gear_damping: float
    gear_friction: float
    gear_friction_speed: float
    # rotors, optional (defaults: the paper's vehicle)
    thrust_planned_max: float = 23.0
    yaw_tilt_thrust_min: float = 5.0

    @property
    def thrust_max(self) -> float:
        """Maximum thrust of one rotor (N)."""
        return self.thrust_coefficient * self.rotor_speed_max**2

    @property
    def tilt_min(self) -> float:
        return math.radians(self.tilt_min_deg)

    @property
    def tilt_max(self) -> float:
        return math.radians(self.tilt_max_deg)

    @property
    def servo_rate_max(self) -> float:
        return math.radians(self.servo_rate_max_deg_s)

    @property
    def aspect_ratio(self) -> float:
        return self.wing_span**2 / self.wing_area

    @property
    def induced_drag_factor(self) -> float:
        """k in C_D = C_D0 + k C_L^2."""
        return 1.0 / (math.pi * self.oswald_efficiency * self.aspect_ratio)

    @property
    def hover_thrust_per_rotor(self) -> float:
        """Thrust each of the four rotors gives at zero tilt in a level hover (N)."""
        return self.mass * self.gravity / len(self.rotor_positions)


# (section, key) -> (attribute, shape, constraint). shape: () scalar, (n,) vector, (n, 3) list of 3-vectors.
# constraint: "positive", "nonnegative", "sign" (+1 or -1) or "" (any finite number).
_SCHEMA: dict[tuple[str, str], tuple[str, tuple[int, ...], str]] = {
    ("mass_properties", "mass"): ("mass", (), "positive"),
    ("mass_properties", "inertia_diag"): ("inertia_diag", (3,), "positive"),
    ("environment", "gravity"): ("gravity", (), "positive"),
    ("environment", "air_density"): ("air_density", (), "positive"),
    ("rotors", "positions"): ("rotor_positions", (4, 3), ""),
    ("rotors", "spin_directions"): ("spin_directions", (4,), "sign"),
    ("rotors", "thrust_coefficient"): ("thrust_coefficient", (), "positive"),
    ("rotors", "torque_coefficient"): ("torque_coefficient", (), "nonnegative"),
    ("rotors", "speed_max"): ("rotor_speed_max", (), "positive"),
    ("rotors", "motor_tau_up"): ("motor_tau_up", (), "positive"),
    ("rotors", "motor_tau_down"): ("motor_tau_down", (), "positive"),
    ("tilt_servos", "tilt_min_deg"): ("tilt_min_deg", (), ""),
    ("tilt_servos", "tilt_max_deg"): ("tilt_max_deg", (), ""),
    ("tilt_servos", "rate_max_deg_s"): ("servo_rate_max_deg_s", (), "positive"),
    ("tilt_servos", "tau"): ("servo_tau", (), "positive"),
    ("wing", "area"): ("wing_area", (), "positive"),
    ("wing", "span"): ("wing_span", (), "positive"),
    ("wing", "mean_chord"): ("mean_chord", (), "positive"),
    ("wing", "CL0"): ("CL0", (), ""),
    ("wing", "CL_alpha"): ("CL_alpha", (), ""),
    ("wing", "CD0"): ("CD0", (), "nonnegative"),
    ("wing", "oswald_efficiency"): ("oswald_efficiency", (), "positive"),
    ("wing", "CY_beta"): ("CY_beta", (), ""),
    ("wing", "Cl_p"): ("Cl_p", (), ""),
    ("wing", "Cm_q"): ("Cm_q", (), ""),
    ("wing", "Cn_r"): ("Cn_r", (), ""),
    ("wing", "stall_blend_rate"): ("stall_blend_rate", (), "positive"),
    ("wing", "stall_alpha0"): ("stall_alpha0", (), "positive"),
    ("aero_effectiveness", "v_onset"): ("eff_v_onset", (), ""),
    ("aero_effectiveness", "v_full"): ("eff_v_full", (), ""),
    ("aero_effectiveness", "width"): ("eff_width", (), "positive"),
    ("aero_effectiveness", "v_zero"): ("eff_v_zero", (), ""),
    ("aero_effectiveness", "ramp_span"): ("eff_ramp_span", (), "positive"),
    ("aero_effectiveness", "ramp_gain"): ("eff_ramp_gain", (), ""),
    ("control_surfaces", "aileron_area"): ("aileron_area", (), "nonnegative"),
    ("control_surfaces", "elevator_area"): ("elevator_area", (), "nonnegative"),
    ("control_surfaces", "rudder_area"): ("rudder_area", (), "nonnegative"),
    ("control_surfaces", "aileron_effectiveness"): ("aileron_effectiveness", (), ""),
    ("control_surfaces", "elevator_effectiveness"): ("elevator_effectiveness", (), ""),
    ("control_surfaces", "rudder_effectiveness"): ("rudder_effectiveness", (), ""),
    ("control_surfaces", "tau"): ("surface_tau", (), "positive"),
    ("control_surfaces", "max_deflection_deg"): ("surface_max_deflection_deg", (), "positive"),
    ("landing_gear", "contact_points"): ("gear_points", (-1, 3), ""),
    ("landing_gear", "stiffness"): ("gear_stiffness", (), "positive"),
    ("landing_gear", "damping"): ("gear_damping", (), "nonnegative"),
    ("landing_gear", "friction"): ("gear_friction", (), "nonnegative"),
    ("landing_gear", "friction_speed"): ("gear_friction_speed", (), "positive"),
    ("rotors", "thrust_planned_max"): ("thrust_planned_max", (), "positive"),
    ("rotors", "yaw_tilt_thrust_min"): ("yaw_tilt_thrust_min", (), "positive"),
}
# Keys a file may leave out: the Airframe field's default (the paper's vehicle) applies.
_OPTIONAL = {("rotors", "thrust_planned_max"), ("rotors", "yaw_tilt_thrust_min")}


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise AirframeError(f"{where}: expected a number, got {value!r}")
    if not math.isfinite(value):
        raise AirframeError(f"{where}: must be finite, got {value!r}")
    return float(value)


def _shaped(value: Any, shape: tuple[int, ...], where: str) -> Any:
    if shape == ():
        return _number(value, where)
    if not isinstance(value, list) or (shape[0] >= 0 and len(value) != shape[0]) or not value:
        want = f"{shape[0]}" if shape[0] >= 0 else "one or more"
        raise AirframeError(f"{where}: expected a list of {want} entries, got {value!r}")
    return tuple(_shaped(v, shape[1:], f"{where}[{i}]") for i, v in enumerate(value))


def _check_constraint(value: Any, constraint: str, where: str) -> None:
    items = value if isinstance(value, tuple) else (value,)
    for v in items:
        if isinstance(v, tuple):
            continue
        if constraint == "positive" and v <= 0:
            raise AirframeError(f"{where}: must be > 0, got {v}")
        if constraint == "nonnegative" and v < 0:
            raise AirframeError(f"{where}: must be >= 0, got {v}")
        if constraint == "sign" and v not in (1.0, -1.0):
            raise AirframeError(f"{where}: must be +1 or -1, got {v}")


def parse_airframe(document: dict[str, Any], origin: str) -> Airframe:
    """Validate a parsed TOML document and build the Airframe. Raises AirframeError."""
    known_sections = {section for section, _ in _SCHEMA}
    for key in document:
        if key != "name" and key not in known_sections:
            raise AirframeError(f"{origin}: unknown section or key '{key}'")
    name = document.get("name")
    if not isinstance(name, str) or not name:
        raise AirframeError(f"{origin}: 'name' must be a non-empty string")
    values: dict[str, Any] = {"name": name}
    for section in sorted(known_sections):
        table = document.get(section)
        if not isinstance(table, dict):
            raise AirframeError(f"{origin}: missing section [{section}]")
        expected = {key for sec, key in _SCHEMA if sec == section}
        for key in table:
            if key not in expected:
                raise AirframeError(f"{origin}: unknown key '{section}.{key}'")
        for key in sorted(expected):
            where = f"{origin}: {section}.{key}"
            entry = table.get(key)
            if entry is None and (section, key) in _OPTIONAL:
                continue
            if entry is None:
                raise AirframeError(f"{where}: missing")
            if not isinstance(entry, dict) or "value" not in entry:
                raise AirframeError(f'{where}: expected {{ value = ..., source = "..." }}')
            if not isinstance(entry.get("source"), str) or not entry["source"].strip():
                raise AirframeError(f"{where}: every number needs a non-empty 'source'")
            attribute, shape, constraint = _SCHEMA[(section, key)]
            value = _shaped(entry["value"], shape, where)
            _check_constraint(value, constraint, where)
            values[attribute] = value
    airframe = Airframe(**values)
    if airframe.tilt_min_deg >= airframe.tilt_max_deg:
        raise AirframeError(f"{origin}: tilt_servos.tilt_min_deg must be below tilt_max_deg")
    return airframe


def load_airframe(path: str | Path | None = None) -> Airframe:
    """Load an airframe file; None loads the packaged default (the paper's vehicle)."""
    if path is None:
        text = resources.files("aircraft.airframes").joinpath(DEFAULT_AIRFRAME).read_text()
        origin = DEFAULT_AIRFRAME
    else:
        origin = str(path)
        try:
            text = Path(path).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise AirframeError(f"{origin}: cannot read: {exc}") from exc
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise AirframeError(f"{origin}: not valid TOML: {exc}") from exc
    return parse_airframe(document, origin)
