"""The requests on the motors' outputs, judged as PX4's commander judges them: MAV_CMD_DO_FLIGHTTERMINATION
(terminate, or clear a termination) and the ground tests MAV_CMD_DO_MOTOR_TEST / MAV_CMD_ACTUATOR_TEST (disarmed
only, with COM_MOT_TEST_EN; autopilot/commander/output_tests.py). The commander keeps what they change: whether the flight is
terminated, and the tests running."""

from __future__ import annotations

from autopilot.commander.commander import ACCEPTED, DENIED, Commander
from autopilot.topics.requests import OutputTest, Reply


class OutputRequests:
    def __init__(self, commander: Commander) -> None:
        self.commander = commander

    def flight_termination(self, on: bool) -> Reply:
        """Terminate (motors off), or clear a termination so that the vehicle can arm again."""
        c = self.commander
        if (refusal := c.refusal()) is not None:
            return refusal
        if on:
            c.terminate_flight("Flight termination: motors off")
        else:
            c.clear_termination()
        return ACCEPTED, None

    def output_test(self, request: OutputTest) -> Reply:
        """Drive (or release) one output of a disarmed vehicle for the request's time-out."""
        c = self.commander
        if (refusal := c.refusal("Actuator test")) is not None:
            return refusal
        if c.armed:
            return DENIED, "Actuator test denied: armed"
        if c.params.get_int("COM_MOT_TEST_EN") != 1:
            return DENIED, "Actuator test denied: COM_MOT_TEST_EN is 0"
        c.drive_output(request.motor, request.index, request.value, request.timeout_s)
        return ACCEPTED, None
