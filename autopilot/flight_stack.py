"""The flight stack as the MAVLink services see it: it takes their typed requests. Arming, modes, takeoff,
landing, transitions and Offboard set-points go to the commander; a failure injection, once SYS_FAILURE_EN
allows it (as PX4's commander checks it), goes to the plant link and is answered when the plant has."""

from __future__ import annotations

from autopilot.commander import Commander
from autopilot.failure_injection import FailureInjection
from autopilot.parameters import ParameterStore
from autopilot.requests import InjectFailure, Reply, Request
from transport.mavlink import mavlink


class FlightStack:
    def __init__(self, commander: Commander, injection: FailureInjection, params: ParameterStore) -> None:
        self.commander = commander
        self.injection = injection
        self.params = params

    def handle(self, request: Request) -> Reply | None:
        if isinstance(request, InjectFailure):
            if self.params.get_int("SYS_FAILURE_EN") != 1:
                return mavlink.MAV_RESULT_DENIED, "Failure injection disabled: set SYS_FAILURE_EN to 1"
            self.injection.request(request.failure, self.commander.now_usec, request.ticket)
            return None  # answered when the plant has acknowledged it
        return self.commander.handle(request)
