"""Compatibility only, for the present autopilot/plant_loop.py and autopilot/cli.py until they build their flight
controllers with autopilot.controllers (controller_kind, build_flight_controller) and hand failures over as
aircraft.failures.Failure: delete this module then. No reflection: a thin adapter over the factory.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from aircraft.airframe import Airframe
from aircraft.failures import Failure, parse_failure
from autopilot.controllers import build_flight_controller, controller_kind
from autopilot.flight_controller import PID, FlightController
from autopilot.parameters import ParameterStore
from autopilot.pid_baseline import TransitionAirspeeds


class LegacyFlightController(FlightController):
    """A FlightController that also takes a failure as MAV_CMD_INJECT_FAILURE's four numbers (plant_loop's call)."""

    def apply_failure(self, failure: Failure | float, *params: float) -> None:  # type: ignore[override]
        super().apply_failure(failure if isinstance(failure, Failure) else parse_failure(failure, *params))


def set_pid_airspeeds(controller: FlightController, blend: float, trans: float) -> None:
    """VT_ARSP_BLEND / VT_ARSP_TRANS into the PID baseline (now FlightController.set_transition_airspeeds)."""
    controller.set_transition_airspeeds(blend, trans)


@dataclass
class ControllerChoice:
    airframe: Airframe
    params: ParameterStore
    forced: str | None = None  # --controller, when given
    say: Callable[[str], None] = lambda text: None  # unused: a broken MPC now raises instead of being announced
    flying: str = PID  # what the last built controller is

    def build(self) -> FlightController:
        kind = controller_kind(self.forced, self.params.get_int("VT_CTRL"))
        airspeeds = TransitionAirspeeds(self.params["VT_ARSP_BLEND"], self.params["VT_ARSP_TRANS"])
        built = build_flight_controller(self.airframe, kind, airspeeds)
        self.flying = built.kind
        return LegacyFlightController(built.airframe, built.allocator, built.servos, built.pid, built.mpc)
