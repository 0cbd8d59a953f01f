"""Which velocity controller flies: `--controller` at start, else the VT_CTRL parameter (0 PID, 1 MPC).

A flight controller is built afresh at start and at every takeoff from the ground, with the parameters of the
moment (VT_CTRL, VT_ARSP_BLEND, VT_ARSP_TRANS). If the MPC cannot be built, the vehicle says so and flies the
PID baseline.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

from aircraft.airframe import Airframe
from autopilot.flight_controller import FlightController
from autopilot.parameters import ParameterStore

PID, MPC = "pid", "mpc"


def pid_of(controller: FlightController):
    """The PID baseline inside a flight controller (the MPC's back-up when the MPC flies)."""
    return getattr(controller, "pid", None) or controller.velocity_controller


def set_pid_airspeeds(controller: FlightController, blend: float, trans: float) -> None:
    """VT_ARSP_BLEND / VT_ARSP_TRANS into the PID baseline's parameters."""
    pid = pid_of(controller)
    if hasattr(pid, "p") and hasattr(pid.p, "arsp_blend"):
        pid.p = replace(pid.p, arsp_blend=blend, arsp_trans=trans)


@dataclass
class ControllerChoice:
    airframe: Airframe
    params: ParameterStore
    forced: str | None = None  # --controller, when given
    say: Callable[[str], None] = lambda text: None
    flying: str = PID  # what the last built controller is

    def wanted(self) -> str:
        if self.forced is not None:
            return self.forced
        return MPC if self.params.get_int("VT_CTRL") == 1 else PID

    def build(self) -> FlightController:
        kind = self.wanted()
        controller = None
        if kind == MPC:
            try:
                controller = FlightController(self.airframe, controller=MPC)
                self.flying = MPC
            except Exception as exc:  # no MPC in this build, or it cannot be set up: the PID flies
                self.say(f"MPC not available ({type(exc).__name__}): flying the PID baseline")
        if controller is None:
            try:
                controller = FlightController(self.airframe, controller=PID)
            except TypeError:  # a FlightController without the choice: the PID baseline only
                controller = FlightController(self.airframe)
            self.flying = PID
        set_pid_airspeeds(controller, self.params["VT_ARSP_BLEND"], self.params["VT_ARSP_TRANS"])
        return controller
