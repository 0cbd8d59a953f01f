"""The aircraft, written once: its parameters (airframe files) and its force and moment model.

Used by the plant (sim_bridge) as truth and by the autopilot (MPC prediction, allocation
effectiveness). Every function evaluates on numbers and on CasADi symbols.
"""

from aircraft.airframe import Airframe, AirframeError, load_airframe

__all__ = ["Airframe", "AirframeError", "load_airframe"]
