"""The flight stack as the MAVLink services see it: it takes their typed requests. Arming, modes, takeoff,
ground-station heartbeats (for the data-link failsafe) and Follow Me's target go to the commander; landing, Go-to,
Orbit, transitions, speed, home and Offboard set-points to its guided requests (guided_requests.py); a failure injection, once
SYS_FAILURE_EN allows it (as PX4's commander checks it), goes to the plant link and is answered when the plant has.
Mission uploads, clears and the current item go to the mission store (autopilot/storage/mission_store.py), which the
navigator reads. A reboot, the parameter storage and the calibrations are taken while disarmed only, as PX4's
commander takes them."""

from __future__ import annotations

from autopilot.commander.calibration import Calibration, Sensor
from autopilot.commander.commander import Commander
from autopilot.commander.failure_injection import FailureInjection
from autopilot.commander.guided_requests import GuidedRequests
from autopilot.commander.output_requests import OutputRequests
from autopilot.navigator.modes.rtl import RETURN
from autopilot.storage.mission_store import MissionStore
from autopilot.storage.parameters import SENSOR_FACTORY_PREFIXES, ParameterFileError, ParameterStore
from autopilot.topics.mission_items import FENCE as FENCE_TYPE
from autopilot.topics.mission_items import MISSION as MISSION_TYPE
from autopilot.topics.requests import (
    Arm,
    Calibrate,
    ChangeSpeed,
    ClearMission,
    Disarm,
    FlightTermination,
    FollowTargetReport,
    GcsHeartbeat,
    InjectFailure,
    Land,
    ManualControlInput,
    OffboardAttitude,
    OffboardPosition,
    OffboardVelocity,
    Orbit,
    OutputTest,
    PreflightStorage,
    Reboot,
    Reply,
    Reposition,
    Request,
    ReturnToLaunch,
    SetHome,
    SetMissionCurrent,
    SetMode,
    SetRegionOfInterest,
    StartMission,
    StoreMission,
    Takeoff,
    Transition,
    TurnTo,
)
from transport.mavlink import mavlink


class FlightStack:
    def __init__(self, commander: Commander, guided: GuidedRequests, outputs: OutputRequests,
                 injection: FailureInjection, params: ParameterStore, missions: MissionStore,
                 calibration: Calibration) -> None:  # fmt: skip
        self.commander = commander
        self.guided = guided
        self.outputs = outputs
        self.injection = injection
        self.params = params
        self.missions = missions
        self.calibration = calibration
        self.reboot_requested = False  # the process restarts once this step's answers are out (autopilot/reboot.py)

    def handle(self, request: Request) -> Reply | None:
        if isinstance(request, Reboot | PreflightStorage | Calibrate):
            return self._preflight(request)
        if isinstance(request, Arm) and self.calibration.running:
            return mavlink.MAV_RESULT_TEMPORARILY_REJECTED, "Arming denied: calibration in progress"
        if isinstance(request, InjectFailure):
            if self.params.get_int("SYS_FAILURE_EN") != 1:
                return mavlink.MAV_RESULT_DENIED, "Failure injection disabled: set SYS_FAILURE_EN to 1"
            self.injection.request(request.failure, self.commander.now_usec, request.ticket)
            return None  # answered when the plant has acknowledged it
        if isinstance(request, StoreMission):
            self.missions.store(request.mission_type, request.items, request.current)
            if request.mission_type in (MISSION_TYPE, FENCE_TYPE):
                self.commander.check_mission()
            return mavlink.MAV_RESULT_ACCEPTED, None
        if isinstance(request, ClearMission):
            self.missions.clear(request.mission_type)
            return mavlink.MAV_RESULT_ACCEPTED, None
        if isinstance(request, SetMissionCurrent):
            if not self.missions.set_current(request.seq):
                return mavlink.MAV_RESULT_DENIED, f"Mission item {request.seq} not in the mission"
            return mavlink.MAV_RESULT_ACCEPTED, None
        return self._commander_request(request)

    def _preflight(self, request: Reboot | PreflightStorage | Calibrate) -> Reply:
        """What PX4's commander does only on the ground: refused while armed (a reboot DENIED, the others
        TEMPORARILY_REJECTED) or while a calibration runs."""
        if self.commander.armed:
            if isinstance(request, Reboot):
                return mavlink.MAV_RESULT_DENIED, "Reboot denied: disarm first"
            return mavlink.MAV_RESULT_TEMPORARILY_REJECTED, "Denied while armed"
        if isinstance(request, Calibrate):
            if request.sensor is None:
                return self.calibration.cancel()
            return self.calibration.start(Sensor(request.sensor))
        if self.calibration.running:
            return mavlink.MAV_RESULT_TEMPORARILY_REJECTED, "Denied while calibrating"
        if isinstance(request, Reboot):
            self.reboot_requested = True
            return mavlink.MAV_RESULT_ACCEPTED, None
        return self._storage(request.action)

    def _storage(self, action: int) -> Reply:
        """PREFLIGHT_STORAGE's parameter actions (PreflightStorage); the texts are PX4's."""
        if action == 0:
            try:
                self.params.reload()
            except ParameterFileError as exc:
                return mavlink.MAV_RESULT_FAILED, f"Error loading settings: {exc}"
        elif action == 1:
            self.params.save()
            error = self.params.flush()
            if error:
                return mavlink.MAV_RESULT_FAILED, f"Error saving settings: {error}"
        elif action in (2, 4):
            self.params.reset()
        elif action == 3:
            self.params.reset(SENSOR_FACTORY_PREFIXES)
        else:
            return mavlink.MAV_RESULT_DENIED, f"Preflight storage: param1 {action} is not 0..4"
        return mavlink.MAV_RESULT_ACCEPTED, None

    def _commander_request(self, request: Request) -> Reply:
        """Arming, modes, guided and output requests and set-points: judged against the current step's state."""
        commander, guided, state = self.commander, self.guided, self.commander.state
        match request:
            case Arm(force=force):
                return commander.arm(state, force)
            case Disarm(force=force):
                return commander.disarm(state, force)
            case Takeoff(altitude_above_home=altitude):
                return commander.takeoff(state, altitude)
            case Land():
                return guided.land(state)
            case SetHome():
                return guided.set_home(request)
            case SetMode(mode=mode):
                return commander.set_mode(mode, state)
            case Transition(target=target):
                return guided.transition(target, state)
            case StartMission():
                return commander.start_mission(state)
            case ReturnToLaunch():
                return commander.set_mode(RETURN, state)
            case ChangeSpeed(speed=speed):
                return guided.change_speed(speed)
            case Reposition() | Orbit():
                return guided.route(request, state)
            case TurnTo():
                return guided.turn_to(request, state)
            case SetRegionOfInterest(roi=roi):
                return guided.point_at(roi)
            case FlightTermination(on=on):
                return self.outputs.flight_termination(on)
            case OutputTest():
                return self.outputs.output_test(request)
            case OffboardVelocity() | OffboardPosition() | OffboardAttitude():
                return guided.offboard_request(request)
            case ManualControlInput():
                return commander.manual_control(request)
            case FollowTargetReport():
                return commander.follow_target(request)
            case GcsHeartbeat():
                commander.gcs_heartbeat()
                return mavlink.MAV_RESULT_ACCEPTED, None
        return mavlink.MAV_RESULT_UNSUPPORTED, f"{type(request).__name__} is not the flight stack's"
